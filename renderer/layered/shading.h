// The surface at a hit (pbrt-v4's GetBSDF): the one call through which the integrator learns how
// a hit scatters light. Shading decides, for every material (Lambert, glTF metallic-roughness,
// and the layered modes: first-order, table with its factors, lambert albedo, random walk),
// which Surface to build, with the stack, tables and hero strata behind it; the integrator sees
// only the Surface interface (renderer/surfaces/surface.h).
#pragma once

#include <cstdint>

#include <glm/vec3.hpp>

#include "materials/spectral/sampled_wavelengths.h"
#include "materials/stack/spectral_stack.h"
#include "materials/stack/stack.h"
#include "renderer/layered/hero_strata.h"
#include "renderer/scene/scene.h"
#include "renderer/surfaces/frame.h"
#include "renderer/surfaces/surface.h"
#include "renderer/surfaces/surface_storage.h"

namespace lamina {

struct LayeredShading;

// The hit as the integrator shades it: both sides of every surface are shaded, so the normals
// are turned towards the viewer.
struct ShadingGeometry {
  glm::dvec3 ng{0.0};  // geometric normal, on the viewer's side
  Frame frame;         // +z the (normal-mapped) shading normal, on the viewer's side
  glm::dvec3 wo{0.0};  // towards the viewer, in the frame
};

// The shading state of one path: the random walks' hero strata, how many walks the path has
// run and, in the spectral mode, the path's wavelengths. Made by Shading::start_path.
class PathShading {
 public:
  // The path's wavelengths in the spectral mode (Spectrum's channels are then these three
  // wavelengths), null in the RGB mode.
  const SampledWavelengths* wavelengths() const { return spectral_ ? &wavelengths_ : nullptr; }

 private:
  friend class Shading;
  HeroStrata strata_;
  bool stratified_ = false;
  int walks_ = 0;                       // random walks run so far on this path (index of the next one)
  std::uint64_t* events_ = nullptr;     // counts the walks' scattering events
  bool spectral_ = false;
  SampledWavelengths wavelengths_;
  // The channel whose wavelength alone the path follows since it entered a leaf (-1: all three;
  // docs/spectral.md, "Leaves: one wavelength through a leaf").
  int one_wavelength_ = -1;
};

class Shading {
 public:
  // layered: null when no material is layered. spectral: paths carry wavelengths
  // (materials/spectral/sampled_wavelengths.h) and RGB inputs are uplifted to them.
  Shading(const SceneDesc& desc, const LayeredShading* layered, bool spectral = false)
      : desc_(desc), layered_(layered), spectral_(spectral) {}

  // The state of the path of sample `sample` of pixel `pixel` (the full image's row-major index);
  // events, if not null, counts the scattering events of its random walks.
  PathShading start_path(std::uint64_t seed, std::uint64_t pixel, std::uint64_t sample, std::uint64_t* events) const;

  // The surface at `hit` seen from wo_world (towards the viewer), built in `storage` (valid
  // until the storage is reused), and its shading geometry.
  const Surface& surface_at(const SurfaceHit& hit, const glm::dvec3& wo_world, PathShading& path,
                            SurfaceStorage& storage, ShadingGeometry* geometry) const;

 private:
  // A layered surface whose index varies with the wavelength (leaf layers), walked at one
  // wavelength of the path.
  const Surface& one_wavelength_walk(const LayerStack& stack, const SpectralStack* spectral, bool from_below,
                                     const SampledWavelengths& w, PathShading& path, SurfaceStorage& storage) const;

  const SceneDesc& desc_;
  const LayeredShading* layered_;
  bool spectral_ = false;
};

}  // namespace lamina
