#include "renderer/layered/gltf_stack.h"

#include <algorithm>
#include <cmath>

namespace lamina {

double albedo_from_diffuse_reflectance(double A) {
  const double r = std::clamp(A, 0.0, 1.0);
  const double b = 1.139 + 1.17 * r;
  const double s = (b - std::sqrt(b * b - 0.556 * (1.0 - r))) / 0.278;
  return std::clamp(1.0 - s * s, 0.0, 1.0);
}

double optical_depth_from_diffuse_transmittance(double D) {
  return (4.0 / 3.0) * (1.0 / D - 1.0);
}

bool has_gltf_stack(const Material& material) { return material.transmissive.transmits(); }

LayerStack gltf_stack(const Material& material, const std::string& where) {
  const Material::Transmissive& t = material.transmissive;
  if (!(t.ior >= 1.0))
    throw SceneError(where + ": material '" + material.name + "': extensions.KHR_materials_ior.ior is below 1, which a " +
                     "transmitting material's stack cannot have");
  const bool thick = t.volume && t.thickness > 0.0;
  // A volume's thicknessFactor is the distance through the object (KHR_materials_volume:
  // "thickness of the volume beneath the surface", baked as the distance to the far side). A ray
  // through a closed mesh crosses two surfaces, each shaded as a slab: each gets half, so the
  // attenuation through the object at normal incidence is Beer-Lambert over the whole thickness.
  const double d = thick ? 0.5 * t.thickness * kMillimetresPerSceneUnit : kThinWallThicknessMm;
  // Scattering optical depth at normal incidence. Clear transmission: the unscattered share of
  // the light that crosses the slab is transmissionFactor (Beer-Lambert, e^-tau). Otherwise the
  // diffuse transmission factor sets it through the Eddington slab.
  double tau = 0.0;
  if (t.transmission && t.transmission_factor > 0.0)
    tau = -std::log(t.transmission_factor);
  else
    tau = optical_depth_from_diffuse_transmittance(t.diffuse_transmission_factor);
  Spectrum sigma_s, sigma_a;
  for (int c = 0; c < 3; ++c) {
    const double alpha = albedo_from_diffuse_reflectance(material.base_color[c]);
    const double sigma_t = tau / d;
    sigma_s[c] = alpha * sigma_t;
    sigma_a[c] = (1.0 - alpha) * sigma_t;
    // KHR_materials_volume: attenuationColor is the transmittance after attenuationDistance
    // (Beer-Lambert: c = exp(-sigma_a x distance)); only a volume (thickness > 0) attenuates.
    // A colour of 0 is read as 1e-6 (finite absorption).
    if (thick && std::isfinite(t.attenuation_distance))
      sigma_a[c] += -std::log(std::max(t.attenuation_color[c], 1e-6)) / (t.attenuation_distance * kMillimetresPerSceneUnit);
  }
  LayerStack stack;
  stack.name = material.name + " (glTF transmission/volume)";
  stack.above_ior = 1.0;
  stack.layers.push_back(make_layer(material.name, t.ior, d, sigma_a, sigma_s, Spectrum(0.0)));
  stack.below.kind = Below::Kind::Dielectric;
  stack.below.ior = 1.0;
  if (const std::string problem = validate_stack(stack); !problem.empty())
    throw SceneError(where + ": material '" + material.name + "': its transmission/volume extensions give an invalid stack (" +
                     problem + ")");
  return stack;
}

}  // namespace lamina
