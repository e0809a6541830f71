// glTF's transmission and volume extensions mapped onto a Hanrahan-Krueger stack, so that a
// material exported from Blender with transmission, diffuse transmission (leaves), volume and IOR
// renders as a layered material without a stack file. Formula by formula, with what is
// approximate: docs/gltf_materials.md. A material's `extras.lamina.stack` or a --materials map
// entry still wins (renderer/layered/material_binding.h).
#pragma once

#include <string>

#include "materials/stack/stack.h"
#include "renderer/scene/scene_gltf.h"

namespace lamina {

// glTF lengths are metres (glTF 2.0 section 3.4); stacks are in millimetres.
constexpr double kMillimetresPerSceneUnit = 1000.0;
// The thickness given to a thin-walled material (no KHR_materials_volume, or thicknessFactor 0):
// only optical depths matter to the position-free stack, so any value would do.
constexpr double kThinWallThicknessMm = 1.0;

// The single-scattering albedo alpha of an isotropic medium whose semi-infinite diffuse albedo
// is A, inverting van de Hulst's relation R = (1 - s)(1 - 0.139 s) / (1 + 1.17 s),
// s = sqrt(1 - alpha) (van de Hulst, "Multiple Light Scattering", 1980; used for this inversion
// by Kulla and Conty, "Revisiting Physically Based Shading at Imageworks", SIGGRAPH 2017 course):
// R (1 + 1.17 s) = (1 - s)(1 - 0.139 s) is the quadratic 0.139 s^2 - (1.139 + 1.17 R) s + 1 - R = 0,
// whose root in [0, 1] is s = [(1.139 + 1.17 R) - sqrt((1.139 + 1.17 R)^2 - 0.556 (1 - R))] / 0.278.
// A is clamped to [0, 1].
double albedo_from_diffuse_reflectance(double A);

// The optical depth tau of a non-absorbing isotropic slab whose diffuse transmittance is D:
// the Eddington (diffusion, two-stream) solution for a conservative slab under diffuse light,
// T = 1 / (1 + 3 tau / 4), inverted: tau = (4/3) (1/D - 1). D in (0, 1].
double optical_depth_from_diffuse_transmittance(double D);

// True if the material's extensions make it layered: a transmission or diffuse transmission
// factor > 0 (KHR_materials_volume and KHR_materials_ior act only together with one of them).
bool has_gltf_stack(const Material& material);

// The stack of a material for which has_gltf_stack() is true: one layer of index ior
// (KHR_materials_ior, default 1.5) in air (above and below), thickness thicknessFactor / 2 x
// kMillimetresPerSceneUnit (a closed mesh is crossed twice; or kThinWallThicknessMm), sigma_a = -ln(attenuationColor) /
// (attenuationDistance x kMillimetresPerSceneUnit) plus the absorption of the scattering part,
// whose optical depth comes from transmissionFactor (e^-tau = factor) or diffuseTransmissionFactor
// (optical_depth_from_diffuse_transmittance) and whose single-scattering albedo is
// albedo_from_diffuse_reflectance(baseColorFactor), g = 0, a smooth top. Throws SceneError naming
// `where` and the material if the result is not a valid stack.
LayerStack gltf_stack(const Material& material, const std::string& where);

}  // namespace lamina
