// The spectral variant of `lamina fit --albedo-texture` (docs/fitting.md, "The spectral
// variant"): a material given by chromophores, two chromophore parameters (melanin and blood
// maps), every texel matched through the spectral albedo table of materials/fit/spectral_albedo.h
// (the physics). The outputs are albedo_maps.h's (parameter maps, materials map, matched albedo,
// report), the report naming the spectral method and counting the clamped texels.
#pragma once

#include <cstddef>
#include <functional>
#include <string>

#include "materials/fit/spectral_albedo.h"
#include "renderer/layered/albedo_maps.h"

namespace lamina {

struct SpectralAlbedoMapsResult {
  AlbedoMapsResult maps;
  // Texels out of the model's gamut: matched with a parameter on a bound of its range (the
  // nearest colour lies on the surface's edge; at_lower/at_upper in `maps` say which bound).
  std::size_t clamped = 0;
};

// Builds the table of `material` over settings.axes (nodes, quadrature points and albedo kind from
// `settings`) and matches every texel of `texture` (linear RGB). Throws FitError for a bad axis.
SpectralAlbedoMapsResult fit_spectral_albedo_maps(const ChromophoreMaterial& material, const Image& texture,
                                                  const AlbedoMapsSettings& settings,
                                                  const std::function<void()>& on_lookup_built = {},
                                                  const std::function<void(std::size_t)>& on_progress = {});

// albedo_maps_report_json's report with "method": "spectral-albedo-lookup", the table's
// wavelengths and interpolation under "lookup", and "clamped": {"texels", "fraction"}.
std::string spectral_albedo_maps_report_json(const SpectralAlbedoMapsResult& result, const AlbedoMapsSettings& settings,
                                             const AlbedoMapsInputs& inputs);

}  // namespace lamina
