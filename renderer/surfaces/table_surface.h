// table mode: the layered surface as a tabulated BRDF/BTDF (materials/tables/layered_table.h: layout,
// interpolation and sampling) plus the exact zeroth order's delta lobes, or, under a rough top,
// the top's own glossy reflection evaluated exactly (its facets, materials/interfaces/microfacet.h;
// the table holds the light that entered the stack, as adding-doubling and the walk tabulate it).
#pragma once

#include <glm/vec3.hpp>

#include "materials/interfaces/microfacet.h"
#include "materials/tables/layered_table.h"
#include "materials/base/spectrum.h"
#include "materials/spectral/sampled_wavelengths.h"
#include "renderer/surfaces/surface.h"
#include "renderer/surfaces/zeroth_order_lobes.h"

namespace lamina {

// One axis's factor T_a(x) / T_0 (renderer/layered/layered_tables.h): on a line, the tables at the
// nodes below and above x and x's weight t towards the upper one; in a plane, also the tables at
// the second dimension's upper node (lo2, hi2) and the weight t2 towards them (bilinear).
struct TableFactor {
  const LayeredTable* lo = nullptr;
  const LayeredTable* hi = nullptr;
  double t = 0.0;
  const LayeredTable* lo2 = nullptr;  // null on a line
  const LayeredTable* hi2 = nullptr;
  double t2 = 0.0;
};

// The spectral mode's table (renderer/layered/spectral_tables.h): for each of the path's
// wavelengths (channel c), the two grid tables around it, the channel of each that holds its grid
// wavelength, and their interpolation weights; `wavelengths` uplifts the RGB factors' ratios.
struct SpectralTableChannels {
  const LayeredTable* table[kChannels][2] = {};
  int channel[kChannels][2] = {};
  double weight[kChannels][2] = {};
  const SampledWavelengths* wavelengths = nullptr;
};

// The model's bin: T_0's bin (node, bin) times the factors (renderer/layered/layered_tables.h).
Spectrum table_model_value(const LayeredTable& base, const TableFactor* factors, int factor_count, int node, int bin);
// The spectral mode's bin: the grid tables interpolated to the path's wavelengths, times the RGB
// factors' ratio to T_0's bin uplifted to them.
Spectrum spectral_table_value(const SpectralTableChannels& spectral, const LayeredTable& base, const TableFactor* factors,
                              int factor_count, int node, int bin);

class TableSurface final : public Bsdf {
 public:
  TableSurface(const LayeredTable& table, const glm::dvec3& wo);
  // With texture-driven parameters: `table` is T_0, the factors scale its bins (evaluation only;
  // sampling and pdf stay T_0's, so the estimate is unbiased for the scaled values), and the
  // exact delta lobes (or a rough top's glossy lobe) come from `hit_stack`, the stack at the hit.
  // spectral: the spectral mode's grid tables at the path's wavelengths, whose interpolation
  // replaces T_0's bin (times the factors' ratios, uplifted); `table` (the RGB T_0) still gives
  // the sampling and the pdf, `hit_stack` is then the stack at the path's wavelengths.
  TableSurface(const LayeredTable& table, const LayerStack& hit_stack, const glm::dvec3& wo, const TableFactor* factors,
               int factor_count, const SpectralTableChannels* spectral = nullptr);
  Spectrum eval(const glm::dvec3& wo, const glm::dvec3& wi) const override;
  bool sample(const glm::dvec3& wo, glm::dvec2 u, BsdfSample* s) const override;
  double pdf(const glm::dvec3& wo, const glm::dvec3& wi) const override;

 private:
  int bin_of(const glm::dvec3& wo, const glm::dvec3& wi) const;
  Spectrum value(int node, int bin) const;  // T_0 times the factors
  const LayeredTable& table_;
  const TableFactor* factors_ = nullptr;
  int factor_count_ = 0;
  const SpectralTableChannels* spectral_ = nullptr;
  ZerothOrderLobes lobes_;
  // A rough top: its reflection lobe, sampled with probability p_glossy_ (the smooth top's
  // Fresnel reflectance at wo, close to the lobe's albedo), in place of the mirror delta.
  bool glossy_ = false;
  RoughDielectric top_;
  double p_glossy_ = 0.0;
  int node_[2] = {0, 0};
  double weight_[2] = {1.0, 0.0};
};

}  // namespace lamina
