// Alpha coverage of glTF materials (glTF 2.0 section 3.9.4 "Alpha Coverage"), applied where rays
// meet surfaces: the Embree scene (scene.cpp) registers a filter on each MASK or BLEND mesh that
// asks keeps_hit() and, if not, lets the ray go on as if the triangle were not there. Camera
// rays, path continuation rays and shadow rays all pass through the same filter, so a cut-out
// leaf is cut out in the image, in its indirect light and in the shadows it casts. Opaque meshes
// get no filter and pay nothing.
#pragma once

#include <cstdint>

#include "renderer/scene/scene_gltf.h"

namespace lamina {

// What the filter of one mesh needs (Embree geometry user data).
struct AlphaCoverage {
  const Mesh* mesh = nullptr;
  const Material* material = nullptr;
  const Texture* texture = nullptr;  // the base colour texture, if it has alpha; else null
  std::uint32_t geometry = 0;        // the mesh's Embree geometry id
};

// alpha = baseColorFactor.a x baseColorTexture.a (at the hit's uv through the base colour's
// KHR_texture_transform) x COLOR_0.a (interpolated), glTF 2.0 section 3.9.4 and 3.7.2.1.
// b1, b2: Embree's barycentrics (p = (1 - b1 - b2) p0 + b1 p1 + b2 p2).
double coverage_alpha(const AlphaCoverage& c, std::uint32_t triangle, double b1, double b2);

// A number in [0, 1) that is a hash of the ray and the primitive it meets: deterministic (the
// same ray meets the same triangle with the same answer, whatever the thread or however many
// times Embree asks), and for distinct rays as good as independent uniform numbers.
double stochastic_alpha_sample(const float origin[3], const float direction[3], std::uint32_t geometry,
                               std::uint32_t triangle);

// Whether the ray's hit on `triangle` counts. MASK: alpha >= alphaCutoff (the spec's "fully
// opaque if greater than or equal to the cutoff, else fully transparent"). BLEND (stochastic
// transparency, Enderton et al., "Stochastic Transparency", I3D 2010): kept if u < alpha, u the
// hash above. A surface of alpha a in front of radiance L_b then gives a L_s + (1 - a) L_b in
// expectation, exactly the "over" blend glTF asks for, per ray and so per pixel, in shadows and
// in indirect light alike: unbiased in expectation, with variance a (1 - a) (L_s - L_b)^2 per
// ray. OPAQUE: always.
bool keeps_hit(const AlphaCoverage& c, std::uint32_t triangle, double b1, double b2, const float origin[3],
               const float direction[3]);

// The probability that keeps_hit() keeps a hit at (b1, b2), over its random number: 1 (OPAQUE),
// 0 or 1 (MASK), alpha (BLEND). What a surface's emission is worth where light sampling picks a
// point on it, so that sampling an emitter agrees with meeting it (alpha-cut emitters).
double expected_coverage(const AlphaCoverage& c, std::uint32_t triangle, double b1, double b2);

}  // namespace lamina
