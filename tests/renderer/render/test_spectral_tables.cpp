// The table and lambert modes in the spectral mode (renderer/layered/spectral_tables.h;
// docs/spectral.md, "Tables and albedos on a wavelength grid"): a flat chromophore slab against
// adding-doubling per wavelength integrated as the film integrates, a grey world equal in both
// modes, the same image for any thread count. Tolerances: 3 standard errors of the image mean
// plus the model's own errors, each computed here, not tuned: the wavelength grid's (the colour
// of the per-wavelength reference interpolated from the grid, minus the reference's), and for
// the table the incidence nodes' (the totals interpolated between the two node cosines around
// the view, minus the totals at the view), and the solver's discretisation estimate.
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <functional>

#include <gtest/gtest.h>

#include "materials/adding_doubling/adding_doubling.h"
#include "materials/spectral/colour.h"
#include "materials/stack/stack_file.h"
#include "materials/tables/albedo.h"
#include "renderer/layered/layered_shading.h"
#include "renderer/layered/layered_tables.h"
#include "renderer/layered/spectral_tables.h"
#include "renderer/layered/wavelength_stack.h"
#include "renderer/render/film.h"
#include "tests/materials/spectral/colour_quadrature.h"
#include "tests/renderer/render_fixtures.h"

namespace lamina {
namespace {

using test::ImageStats;
using test::make_scene;
using test::stats_of;

// A two-layer skin by chromophores (blood's bands and melanin's slope in the visible), smooth top.
const char* kSkin = R"({"lamina_material": 1, "layers": [
    {"ior": 1.4, "thickness": 0.1, "chromophores": {"melanin": 0.05, "baseline": 0.5,
     "scattering": {"reduced_500": 4.6, "f_rayleigh": 0.409, "b_mie": 0.702}, "g": 0.8}},
    {"ior": 1.4, "thickness": "inf", "chromophores": {"blood": 0.02, "oxygenation": 0.75, "water": 0.6, "baseline": 0.38,
     "scattering": {"reduced_500": 4.6, "f_rayleigh": 0.409, "b_mie": 0.702}, "g": 0.8}}]})";

const char* kGrey = R"({"lamina_material": 1, "layers": [
    {"ior": 1.4, "thickness": 0.3, "sigma_a": 0.4, "sigma_s": 6.0, "g": 0.6},
    {"ior": 1.4, "thickness": "inf", "sigma_a": 0.1, "sigma_s": 10.0, "g": 0.2}]})";

// A scene's one layered material in a mode, with what that mode needs (tables, grid).
struct Shaded {
  LayeredBindings bindings;
  std::vector<std::shared_ptr<const SpectralStack>> chromophores;
  std::unique_ptr<LayeredTables> tables;
  std::unique_ptr<SpectralTables> spectral_tables;
  LayeredShading layered;
  Shaded(const char* text, SubsurfaceMode mode, bool spectral) {
    bindings.by_material.push_back(std::make_shared<const LayeredMaterial>(parse_stack_json(text, "m"), "m"));
    const SpectralStack s = parse_spectral_stack_json(text, "m");
    bool any = false;
    for (const auto& c : s.chromophores) any = any || c.has_value();
    chromophores = {any ? std::make_shared<const SpectralStack>(s) : nullptr};
    const TableSettings settings;
    if (mode == SubsurfaceMode::Table) tables = std::make_unique<LayeredTables>(bindings, settings);
    if (spectral)
      spectral_tables = std::make_unique<SpectralTables>(bindings, chromophores, tables.get(), std::vector<bool>{mode == SubsurfaceMode::Table},
                                                         std::vector<bool>{mode == SubsurfaceMode::Lambert}, settings);
    layered.bindings = &bindings;
    layered.mode = mode;
    layered.tables = tables.get();
    layered.spectral_tables = spectral_tables.get();
    layered.spectral = chromophores;
  }
};

Image render_slab(const Shaded& m, double theta, int size, int spp, bool spectral, int threads = 0) {
  const Scene scene{make_scene({test::slab_plane(0)})};
  RenderSettings s;
  s.width = s.height = size;
  s.spp = spp;
  s.seed = 5;
  s.threads = threads;
  s.layered = &m.layered;
  s.spectral = spectral;
  return test::render_valid(scene, EnvironmentMap::constant(Spectrum(1.0)), test::camera_towards(test::world_dir(theta, 0.0)), s);
}

// A per-wavelength quantity of the stack at nm (three at a time, as a grid stack holds them).
using Quantity = std::function<Spectrum(const LayerStack&)>;
std::vector<double> at(const Shaded& m, const std::vector<double>& nm, const Quantity& q) {
  std::vector<double> out(nm.size());
  for (std::size_t i = 0; i < nm.size(); i += 3) {
    auto n = [&](std::size_t k) { return nm[std::min(i + k, nm.size() - 1)]; };
    LayerStack stack;
    stack_at_wavelengths(m.bindings.by_material[0]->base_stack(), m.chromophores[0].get(), false, SampledWavelengths::at(n(0), n(1), n(2)),
                         &stack);
    const Spectrum v = q(stack);
    for (std::size_t k = 0; k < 3 && i + k < nm.size(); ++k) out[i + k] = v[static_cast<int>(k)];
  }
  return out;
}

Spectrum colour_of(const std::vector<double>& nm, const std::vector<double>& r) {
  const TabulatedSpectrum refl(nm, r);
  return test::colour_by_quadrature([&](double l) { return refl(l); });
}

// The reference colour of q every 2 nm, and the grid's interpolation error on it.
Spectrum reference(const Shaded& m, const Quantity& q, Spectrum* grid_error) {
  std::vector<double> fine, grid;
  for (double nm = kSpectralFirstNm; nm <= kSpectralLastNm + 1e-9; nm += 2.0) fine.push_back(nm);
  const WavelengthTableGrid g;
  for (int j = 0; j < g.count; ++j) grid.push_back(g.nm(j));
  const Spectrum exact = colour_of(fine, at(m, fine, q));
  *grid_error = colour_of(grid, at(m, grid, q)) - exact;
  return exact;
}

void expect_within(const ImageStats& rendered, const Spectrum& expected, const Spectrum& model_error, const char* what) {
  for (int c = 0; c < 3; ++c) {
    const double tol = 3.0 * rendered.stderr_[c] + std::abs(model_error[c]);
    if (std::getenv("LAMINA_TEST_VERBOSE"))
      std::printf("%s, channel %d: rendered %g +- %g, expected %g (model error %g)\n", what, c, rendered.mean[c], rendered.stderr_[c],
                  expected[c], model_error[c]);
    EXPECT_NEAR(rendered.mean[c], expected[c], tol) << what << ", channel " << c << ": rendered " << rendered.mean[c] << " +- "
                                                    << rendered.stderr_[c] << ", expected " << expected[c] << " (model error "
                                                    << model_error[c] << ")";
  }
}

Spectrum abs_sum(const Spectrum& a, const Spectrum& b) {
  Spectrum s;
  for (int c = 0; c < 3; ++c) s[c] = std::abs(a[c]) + std::abs(b[c]);
  return s;
}

// The slab under a uniform white sky (Le = 1), seen at 35 degrees: each pixel is the directional
// albedo at the view, R_specular + R_diffuse at 35 degrees (reciprocity). The table interpolates
// the diffuse part between its incidence nodes: that error is measured on the adding-doubling
// totals at the two nodes around the view.
TEST(SpectralTables, FlatChromophoreSlabInTheTableModeAgreesWithAddingDoublingPerWavelength) {
  const Shaded m(kSkin, SubsurfaceMode::Table, true);
  const double theta = 35.0, mu = std::cos(theta * kPi / 180.0);
  const TableNodes nodes = table_nodes_at(TableSettings{}, mu);
  auto total = [](double cosine) {
    return Quantity([cosine](const LayerStack& s) {
      const AddingDoublingTotals t = adding_doubling_totals(s, cosine);
      return t.R_specular + t.R_diffuse;
    });
  };
  // The table's model of the view: R_specular exact at mu, R_diffuse interpolated between nodes.
  const Quantity model = [&](const LayerStack& s) {
    const AddingDoublingTotals t = adding_doubling_totals(s, mu);
    Spectrum d;
    for (int k = 0; k < 2; ++k)
      d += adding_doubling_totals(s, table_node_cosine(TableSettings{}, nodes.node[k])).R_diffuse * nodes.weight[k];
    return t.R_specular + d;
  };
  Spectrum grid_error, unused;
  const Spectrum expected = reference(m, total(mu), &grid_error);
  const Spectrum node_error = reference(m, model, &unused) - expected;
  // The solver's discretisation estimate (its N against N/2 points), as a colour.
  const Spectrum solver_error = reference(m, [mu](const LayerStack& s) {
    const AddingDoublingEstimate e = adding_doubling_with_error(s, mu);
    return e.error.R_specular + e.error.R_diffuse;
  }, &unused);
  const ImageStats rendered = stats_of(render_slab(m, theta, 24, 16, true));
  expect_within(rendered, expected, abs_sum(abs_sum(grid_error, node_error), solver_error), "table");
}

// The lambert mode: the slab is a Lambert surface of the stack's diffuse albedo at each wavelength
// (adding-doubling), so under the white sky each pixel is that albedo's colour.
TEST(SpectralTables, FlatChromophoreSlabInTheLambertModeIsItsAlbedoPerWavelength) {
  const Shaded m(kSkin, SubsurfaceMode::Lambert, true);
  Spectrum grid_error;
  const Spectrum expected =
      reference(m, [](const LayerStack& s) { return diffuse_bihemispherical_albedo_adding_doubling(s); }, &grid_error);
  const ImageStats rendered = stats_of(render_slab(m, 35.0, 24, 16, true));
  expect_within(rendered, expected, grid_error, "lambert");
  // Colour from the wavelengths: red well above blue, as skin's albedo.
  EXPECT_GT(rendered.mean[0], 2.0 * rendered.mean[2]);
}

// A grey stack: its tables and albedo are the same at every wavelength, so the spectral image's
// mean is the RGB image's, within 3 standard errors of their difference.
TEST(SpectralTables, GreyWorldIsTheSameInBothModes) {
  for (const SubsurfaceMode mode : {SubsurfaceMode::Table, SubsurfaceMode::Lambert}) {
    const Shaded rgb(kGrey, mode, false), spectral(kGrey, mode, true);
    const ImageStats a = stats_of(render_slab(rgb, 50.0, 16, 16, false)), b = stats_of(render_slab(spectral, 50.0, 16, 16, true));
    for (int c = 0; c < 3; ++c)
      EXPECT_NEAR(b.mean[c], a.mean[c], 3.0 * std::hypot(a.stderr_[c], b.stderr_[c]) + 1e-9)
          << subsurface_mode_name(mode) << ", channel " << c;
  }
}

TEST(SpectralTables, SameImageForAnyThreadCount) {
  const Shaded m(kSkin, SubsurfaceMode::Table, true);
  const Image a = render_slab(m, 35.0, 19, 3, true, 1), b = render_slab(m, 35.0, 19, 3, true, 2);
  ASSERT_EQ(a.rgb.size(), b.rgb.size());
  EXPECT_EQ(0, std::memcmp(a.rgb.data(), b.rgb.data(), a.rgb.size() * sizeof(float)));
}

// The grid: nodes at 360 and 830 nm, evenly spaced, and `locate` brackets every wavelength.
TEST(SpectralTables, GridSpansTheSampledRange) {
  const WavelengthTableGrid g;
  EXPECT_EQ(g.count % 3, 0);
  EXPECT_DOUBLE_EQ(g.nm(0), kSpectralFirstNm);
  EXPECT_DOUBLE_EQ(g.nm(g.count - 1), kSpectralLastNm);
  for (double nm : {360.0, 361.0, 555.5, 829.9, 830.0}) {
    int j = 0;
    double t = 0.0;
    g.locate(nm, &j, &t);
    EXPECT_GE(j, 0);
    EXPECT_LE(j + 1, g.count - 1);
    EXPECT_NEAR((1.0 - t) * g.nm(j) + t * g.nm(j + 1), nm, 1e-9);
  }
}

}  // namespace
}  // namespace lamina
