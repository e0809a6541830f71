// The table mode's surface over a rough top (renderer/surfaces/table_surface.h): the tabulated
// light that entered the stack plus the top's glossy lobe evaluated exactly. Its directional
// albedo equals adding-doubling's total reflectance (the lobe's power is the solver's
// R_specular, the bins' its R_diffuse), and its sampler agrees with its eval and pdf.
#include <cmath>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "materials/adding_doubling/adding_doubling.h"
#include "materials/analytic/first_order.h"  // gauss_legendre
#include "materials/base/sampling.h"
#include "materials/stack/stack_file.h"
#include "materials/tables/layered_table.h"
#include "renderer/surfaces/table_surface.h"

namespace lamina {
namespace {

constexpr double kPiD = 3.14159265358979323846;

LayerStack rough_skin() {
  LayerStack s = load_stack_file(std::string(LAMINA_SOURCE_DIR) + "/scenes/materials/skin.json");
  s.top_roughness = 0.35;
  s.interface_model = InterfaceModel::SingleScattering;
  return s;
}

// int eval(wo, w) |cos| dw over the upper hemisphere: Gauss-Legendre in the polar angle on
// pieces that put the glossy peak (the mirror direction) on an edge, midpoint in phi.
Spectrum albedo_by_quadrature(const TableSurface& surface, const glm::dvec3& wo) {
  const double theta_mirror = std::acos(wo.z);
  std::vector<double> edges{0.0, 0.5 * kPiD};
  if (theta_mirror > 0.0) edges.insert(edges.begin() + 1, theta_mirror);
  constexpr int kTheta = 200, kPhi = 720;
  std::vector<double> x(kTheta), w(kTheta);
  Spectrum sum(0.0);
  for (std::size_t p = 0; p + 1 < edges.size(); ++p) {
    gauss_legendre(kTheta, edges[p], edges[p + 1], x.data(), w.data());
    for (int i = 0; i < kTheta; ++i)
      for (int k = 0; k < kPhi; ++k) {
        const double phi = (k + 0.5) * 2.0 * kPiD / kPhi;
        const glm::dvec3 wi{std::sin(x[i]) * std::cos(phi), std::sin(x[i]) * std::sin(phi), std::cos(x[i])};
        sum += surface.eval(wo, wi) * (std::cos(x[i]) * std::sin(x[i]) * w[i] * 2.0 * kPiD / kPhi);
      }
  }
  return sum;
}

// At a table node (no interpolation between nodes), the surface's albedo is the solver's
// R_specular + R_diffuse: the glossy lobe evaluated exactly integrates to the projection's
// R_specular (to 2e-4: both converged quadratures of the same integral, measured 3e-5), and
// the bins to R_diffuse up to their cosine quadrature (kBinPower of the bin test, 2e-3).
TEST(RoughTableSurface, AlbedoIsTheSolversTotalReflectance) {
  const LayerStack s = rough_skin();
  TableSettings ts;
  ts.nodes = 5;
  const LayeredTable table = build_layered_table(s, ts);
  for (int j : {1, 3, 4}) {
    const double mu = table_node_cosine(ts, j);
    const glm::dvec3 wo{std::sqrt(1.0 - mu * mu), 0.0, mu};
    const TableSurface surface(table, wo);
    const Spectrum a = albedo_by_quadrature(surface, wo);
    const AddingDoublingTotals t = adding_doubling_totals(s, mu);
    for (int c = 0; c < kChannels; ++c)
      EXPECT_NEAR(a[c], t.R_specular[c] + t.R_diffuse[c], 2e-4 + 2e-3 * t.R_diffuse[c]) << "mu " << mu << " channel " << c;
  }
}

// Sampling: the mean of f |cos| / pdf over the surface's own samples is its albedo by
// quadrature (within 4 standard errors), and every sample's f and pdf are eval's and pdf's.
TEST(RoughTableSurface, SamplerAgreesWithEvalAndPdf) {
  const LayerStack s = rough_skin();
  TableSettings ts;
  ts.nodes = 5;
  const LayeredTable table = build_layered_table(s, ts);
  const double mu = 0.6;
  const glm::dvec3 wo{std::sqrt(1.0 - mu * mu), 0.0, mu};
  const TableSurface surface(table, wo);
  const Spectrum a = albedo_by_quadrature(surface, wo);
  constexpr int kN = 400000;
  double sum = 0.0, sum2 = 0.0;
  for (int n = 0; n < kN; ++n) {
    Rng rng(5, n);
    const double u0 = rng.uniform(), u1 = rng.uniform();
    BsdfSample smp;
    if (!surface.sample(wo, {u0, u1}, &smp)) continue;
    ASSERT_FALSE(smp.delta);
    ASSERT_GT(smp.pdf, 0.0);
    EXPECT_NEAR(smp.pdf, surface.pdf(wo, smp.wi), 1e-12 * smp.pdf);
    const double v = smp.f[1] * std::abs(smp.wi.z) / smp.pdf;
    sum += v;
    sum2 += v * v;
  }
  const double mean = sum / kN, se = std::sqrt((sum2 / kN - mean * mean) / kN);
  EXPECT_NEAR(mean, a[1], 4.0 * se) << "stderr " << se;
}

// Energy-conserving rough interfaces (docs/adding_doubling.md, "Energy-conserving rough
// interfaces"): the table holds all but the top's first-order glossy lobe, which the surface
// evaluates exactly, and the delta lobes of the smooth interfaces above the first rough one. At
// a node the surface's albedo plus those deltas is the solver's total reflectance, as above (the
// bins' cosine quadrature, 2e-3 of what they hold), on rough skin and on a stack with a smooth top
// and a rough inner interface.
TEST(RoughTableSurface, EnergyConservingAlbedoIsTheSolversTotalReflectance) {
  LayerStack top = rough_skin();
  top.interface_model = InterfaceModel::EnergyConserving;
  LayerStack inner = load_stack_file(std::string(LAMINA_SOURCE_DIR) + "/scenes/materials/skin.json");
  inner.interface_model = InterfaceModel::EnergyConserving;
  inner.layers[1].ior = 1.55;
  inner.layers[0].bottom_roughness = 0.3;
  ASSERT_EQ(validate_stack(inner), "");
  for (const LayerStack* s : {&top, &inner}) {
    TableSettings ts;
    ts.nodes = 5;
    const LayeredTable table = build_layered_table(*s, ts);
    for (int j : {1, 3, 4}) {
      const double mu = table_node_cosine(ts, j);
      const glm::dvec3 wo{std::sqrt(1.0 - mu * mu), 0.0, mu};
      const TableSurface surface(table, wo);
      const Spectrum a = albedo_by_quadrature(surface, wo) + zeroth_order_above_rough(*s, mu).R_specular;
      const AddingDoublingTotals t = adding_doubling_totals(*s, mu);
      for (int c = 0; c < kChannels; ++c) {
        const double R = t.R_specular[c] + t.R_diffuse[c];
        EXPECT_NEAR(a[c], R, 2e-4 + 2e-3 * R) << (s == &top ? "rough top" : "rough inner") << " mu " << mu << " channel " << c;
      }
    }
  }
}

}  // namespace
}  // namespace lamina
