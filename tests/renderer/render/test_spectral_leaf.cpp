// Leaves in the spectral mode (docs/spectral.md, "Leaves: one wavelength through a leaf"): a leaf
// layer's index varies with the wavelength, so a path follows one wavelength through it, its
// estimate 3 times in that channel and 0 in the others. Tolerances as in test_spectral_render.cpp:
// the image mean of N independent pixels has standard error s / sqrt(N).
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <optional>
#include <string>

#include <unistd.h>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "materials/adding_doubling/spectral_totals.h"
#include "materials/spectral/sampled_wavelengths.h"
#include "materials/stack/stack_file.h"
#include "renderer/image/image_io.h"
#include "renderer/layered/layered_shading.h"
#include "renderer/layered/stack_bindings.h"
#include "renderer/layered/wavelength_stack.h"
#include "renderer/render/film.h"
#include "tests/materials/spectral/colour_quadrature.h"
#include "tests/renderer/render_fixtures.h"
#include "tests/support/image_files.h"

namespace lamina {
namespace {

using test::ImageStats;
using test::make_scene;
using test::stats_of;

bool verbose() { return std::getenv("LAMINA_TEST_VERBOSE") != nullptr; }

// A sky of radiance 1 (D65 of luminance 1) above the horizon and black below (or, lower, the
// other way round): an equirectangular map of two rows, the top one the upper hemisphere
// (renderer/render/environment.h).
EnvironmentMap half_sky(bool lower) {
  Image sky(4, 2);
  for (int x = 0; x < 4; ++x)
    for (int c = 0; c < 3; ++c) sky.pixel(x, lower ? 1 : 0)[c] = 1.0f;
  const std::string path = (std::filesystem::temp_directory_path() / ("lamina_upper_sky_" + std::to_string(::getpid()) + ".exr")).string();
  write_exr(path, sky);
  EnvironmentMap env = EnvironmentMap::from_file(path);
  std::filesystem::remove(path);
  return env;
}

// A flat slab of material `m` (its top facing +y) under the upper sky, seen at theta degrees from
// above (below: false) or from below. From above every pixel shows the directional reflectance at
// theta, from below the directional transmittance of light arriving from below at theta (by
// reciprocity, the same medium, air, on both sides): the totals of adding-doubling. Under the
// lower sky (lower_sky), seen from below: the reflectance of the bottom face. `spectral_layers`:
// the file's chromophore and leaf layers, as render_job gives them (spectral_stacks), or null.
Image render_material(std::shared_ptr<const LayeredMaterial> m, std::shared_ptr<const SpectralStack> spectral_layers,
                      bool spectral, bool one_wavelength_walks, bool below, double theta, int size, int spp,
                      std::uint64_t seed, bool lower_sky = false) {
  LayeredBindings b;
  b.by_material.push_back(std::move(m));
  LayeredShading layered;
  layered.bindings = &b;
  if (spectral_layers) layered.spectral = {std::move(spectral_layers)};
  layered.test_hooks.one_wavelength_walks = one_wavelength_walks;
  const Scene scene{make_scene({test::slab_plane(0)})};
  RenderSettings s;
  s.width = s.height = size;
  s.spp = spp;
  s.seed = seed;
  s.layered = &layered;
  s.spectral = spectral;
  return test::render_valid(scene, half_sky(lower_sky), test::camera_towards(test::world_dir(theta, 0.0, below)), s);
}

// The slab of the material file `json` (render_material).
Image render_slab(const std::string& json, bool spectral, bool one_wavelength_walks, bool below, double theta, int size,
                  int spp, std::uint64_t seed, bool lower_sky = false) {
  // A file with leaf layers as the spectral mode reads it (render_job: spectral_stacks), any
  // other as the RGB mode does (in the spectral mode its coefficients are uplifted).
  const bool leaf = json.find("\"leaf\"") != std::string::npos;
  auto m = std::make_shared<const LayeredMaterial>(leaf ? parse_spectral_stack_json(json, "leaf").stack : parse_stack_json(json, "slab"),
                                                   "slab");
  return render_material(std::move(m), leaf ? std::make_shared<const SpectralStack>(parse_spectral_stack_json(json, "leaf")) : nullptr,
                         spectral, one_wavelength_walks, below, theta, size, spp, seed, lower_sky);
}

// A grey slab that transmits, given in RGB: in the spectral mode its index is the same at every
// wavelength, so its three-wavelength walk is exact, and the RGB mode renders the same image
// mean (a grey world). Rendered with every walk following one wavelength (the leaf's estimator),
// it must give the RGB image's mean from above and from below: the estimator's factor 3, the
// channel's choice and the film's division by the wavelength density together. Prints, with
// LAMINA_TEST_VERBOSE, the variance of each channel over pixels with one and with three
// wavelengths per walk: the colour noise the leaf's estimator costs.
const char* kGreySlab = R"({"lamina_material": 1, "layers": [
    {"ior": 1.45, "thickness": 0.2, "sigma_a": 0.6, "sigma_s": 8.0, "g": 0.8}], "below": {"ior": 1.0}})";

TEST(SpectralLeaf, OneWavelengthWalksOfAConstantIndexEqualTheRgbGreySlab) {
  for (const bool below : {false, true}) {
    const char* side = below ? "grey slab, transmittance (camera below)" : "grey slab, reflectance (camera above)";
    const ImageStats rgb = stats_of(render_slab(kGreySlab, false, false, below, 30.0, 24, 16, 3));
    const ImageStats one = stats_of(render_slab(kGreySlab, true, true, below, 30.0, 24, 16, 4));
    for (int c = 0; c < 3; ++c)
      EXPECT_NEAR(one.mean[c], rgb.mean[c], 3.0 * std::hypot(rgb.stderr_[c], one.stderr_[c]) + 2e-4)
          << side << ", channel " << c << ": RGB " << rgb.mean[c] << " +- " << rgb.stderr_[c] << ", one wavelength "
          << one.mean[c] << " +- " << one.stderr_[c];
    // It is the leaf's estimator that ran: one wavelength per walk leaves colour noise that three
    // wavelengths of a grey slab (the same value at each) do not have.
    const ImageStats three = stats_of(render_slab(kGreySlab, true, false, below, 30.0, 24, 16, 4));
    EXPECT_GT(one.stderr_[2], 1.5 * three.stderr_[2]) << side;
    if (verbose())
      for (int c = 0; c < 3; ++c)
        std::printf("%s, channel %d: mean %g; pixel variance, one wavelength / three: %g\n", side, c, one.mean[c],
                    std::pow(one.stderr_[c] / three.stderr_[c], 2.0));
  }
}

// A green leaf given in RGB (scenes/materials/leaf.json, uplifted in the spectral mode: its index
// the same at every wavelength): one wavelength per walk gives the three-wavelength walk's image
// mean, from above and from below. With LAMINA_TEST_VERBOSE, the colour noise that costs on a
// coloured leaf (the variance of each channel over pixels, one wavelength / three).
const char* kRgbLeaf = R"({"lamina_material": 1, "layers": [
    {"ior": 1.45, "thickness": 0.02, "sigma_a": 0.0, "sigma_s": 5.0, "g": 0.9},
    {"ior": 1.45, "thickness": 0.18, "components": [
      {"fraction": 0.3, "sigma_a": [29.1648, 10.8828, 75.1913], "sigma_s": 24.0, "g": 0.5},
      {"fraction": 0.7, "sigma_a": [0.1643, 0.1643, 0.4757], "sigma_s": 24.0, "g": 0.5}]}],
    "below": {"ior": 1.0}})";

void expect_one_wavelength_walks_equal_three(const std::string& json, const char* leaf) {
  for (const bool below : {false, true}) {
    const std::string side = std::string(leaf) + (below ? ", transmittance (camera below)" : ", reflectance (camera above)");
    const ImageStats three = stats_of(render_slab(json, true, false, below, 30.0, 24, 32, 5));
    const ImageStats one = stats_of(render_slab(json, true, true, below, 30.0, 24, 32, 6));
    for (int c = 0; c < 3; ++c) {
      EXPECT_NEAR(one.mean[c], three.mean[c], 3.0 * std::hypot(three.stderr_[c], one.stderr_[c]))
          << side << ", channel " << c << ": three wavelengths " << three.mean[c] << " +- " << three.stderr_[c]
          << ", one " << one.mean[c] << " +- " << one.stderr_[c];
      if (verbose())
        std::printf("%s, channel %d: mean %g; pixel variance, one wavelength / three: %g\n", side.c_str(), c, one.mean[c],
                    std::pow(one.stderr_[c] / three.stderr_[c], 2.0));
    }
  }
}

TEST(SpectralLeaf, OneWavelengthWalksOfAnRgbLeafEqualItsThreeWavelengthWalks) {
  expect_one_wavelength_walks_equal_three(kRgbLeaf, "RGB leaf");
}

// The same with a diffusely transmitting top (docs/layered_rendering.md, "Diffusely transmitting
// interfaces"): the one-wavelength walks pass through the diffuse surface's arrivals and sources
// as the three-wavelength walks do.
TEST(SpectralLeaf, OneWavelengthWalksOfAnRgbLeafWithADiffuseTopEqualItsThreeWavelengthWalks) {
  std::string json = kRgbLeaf;
  json.insert(json.find("\"layers\""), "\"top_diffuse\": true, ");
  expect_one_wavelength_walks_equal_three(json, "RGB leaf with a diffuse top");
}

// A flat layered leaf (the fitted mature green leaf of docs/spectral.md, "Layered leaf":
// cuticle, palisade and spongy mesophyll by PROSPECT-D's pigments, index PROSPECT-D's), smooth.
const char* kLeaf = R"({"lamina_material": 1, "layers": [
    {"thickness": 0.003, "leaf": {}},
    {"thickness": 0.1, "leaf": {"chlorophyll": 15.936, "carotenoids": 3.1872, "water": 0.003984, "dry_matter": 0.003586,
     "plates": 0.2886, "scattering_power": -0.0398, "g": 0.95}},
    {"thickness": 0.12, "leaf": {"chlorophyll": 24.064, "carotenoids": 4.8128, "water": 0.006016, "dry_matter": 0.005414,
     "plates": 1.5433, "scattering_power": -0.0398, "g": 0.95}}]})";

// The colour of a spectrum given on `nm` (read linearly between), as the film integrates it.
Spectrum colour_of(const std::vector<double>& nm, const std::vector<double>& r) {
  const TabulatedSpectrum refl(nm, r);
  return test::colour_by_quadrature([&](double l) { return refl(l); });
}

// The colour of `seen`'s reflectance (or transmittance) at mu by adding-doubling every `step` nm,
// integrated as the film integrates; *error (if not null): the colour of the solver's own
// discretisation error estimate.
Spectrum adding_doubling_colour(const SpectralStack& seen, double mu, bool transmitted, double step, Spectrum* error) {
  const SpectralTotals t = adding_doubling_spectrum(seen, WavelengthGrid::from_to(kSpectralFirstNm, kSpectralLastNm, step), mu);
  std::vector<double> v, e;
  for (const AddingDoublingEstimate& est : t.estimates) {
    const AddingDoublingTotals& a = est.totals;
    const AddingDoublingTotals& d = est.error;
    v.push_back(transmitted ? a.T_ballistic[0] + a.T_diffuse[0] : a.R_specular[0] + a.R_diffuse[0]);
    e.push_back(transmitted ? d.T_ballistic[0] + d.T_diffuse[0] : d.R_specular[0] + d.R_diffuse[0]);
  }
  if (error) *error = colour_of(t.nm, e);
  return colour_of(t.nm, v);
}

// The tolerance of a rendered image mean against adding-doubling every 2 nm: 3 standard errors,
// plus the solver's own discretisation error and the 2-nm grid's interpolation (its difference
// from a 4-nm grid's colour). Fills *expected.
Spectrum adding_doubling_tolerance(const SpectralStack& seen, double mu, bool transmitted, const ImageStats& rendered,
                                   Spectrum* expected) {
  Spectrum solver_error;
  *expected = adding_doubling_colour(seen, mu, transmitted, 2.0, &solver_error);
  const Spectrum coarser = adding_doubling_colour(seen, mu, transmitted, 4.0, nullptr);
  Spectrum tol;
  for (int c = 0; c < 3; ++c)
    tol[c] = 3.0 * rendered.stderr_[c] + std::abs(solver_error[c]) + std::abs((*expected)[c] - coarser[c]);
  return tol;
}

// The leaf under the upper sky, rendered spectrally from above (its reflectance) and from below
// (its transmittance), against adding-doubling per wavelength every 2 nm (the leaf seen from
// below: the flipped stack) integrated as the film integrates. Tolerance: 3 standard errors of
// the image mean, plus the solver's own discretisation error and the 2-nm grid's interpolation
// (its difference from a 4-nm grid's colour). Fails if the leaf's index were not followed per
// wavelength (the index at 550 nm moves the reflectance of the top surface), if the flipped
// stack's layers kept the file's order, or if the factor 3 were missing.
void expect_flat_leaf_matches_adding_doubling(const char* json, std::uint64_t seed) {
  const SpectralStack leaf = parse_spectral_stack_json(json, "leaf");
  const double theta = 30.0, mu = std::cos(theta * kPi / 180.0);
  struct Case {
    const char* what;
    bool below, lower_sky, transmitted;
  };
  for (const Case& k : {Case{"reflectance of the top (camera above)", false, false, false},
                        Case{"transmittance (camera below)", true, false, true},
                        Case{"reflectance of the bottom (camera below, the sky below)", true, true, false}}) {
    const ImageStats rendered = stats_of(render_slab(json, true, false, k.below, theta, 32, 64, seed, k.lower_sky));
    const SpectralStack seen = k.below ? flipped(leaf) : leaf;
    Spectrum expected;
    const Spectrum tol = adding_doubling_tolerance(seen, mu, k.transmitted, rendered, &expected);
    for (int c = 0; c < 3; ++c) {
      if (verbose())
        std::printf("%s, channel %d: rendered %g +- %g, adding-doubling %g (tolerance %g)\n", k.what, c, rendered.mean[c],
                    rendered.stderr_[c], expected[c], tol[c]);
      EXPECT_NEAR(rendered.mean[c], expected[c], tol[c])
          << k.what << ", channel " << c << ": rendered " << rendered.mean[c] << " +- " << rendered.stderr_[c]
          << ", adding-doubling " << expected[c];
    }
  }
}

TEST(SpectralLeaf, FlatLeafAgreesWithAddingDoublingPerWavelength) { expect_flat_leaf_matches_adding_doubling(kLeaf, 7); }

// The same leaf with a diffusely transmitting top (PROSPECT's plate surface; docs/
// layered_rendering.md, "Diffusely transmitting interfaces"): seen from below its diffuse face is
// the flipped stack's bottom, whose arrivals connect to the sky above.
TEST(SpectralLeaf, FlatLeafWithADiffuseTopAgreesWithAddingDoublingPerWavelength) {
  const std::string json = std::string(kLeaf).replace(std::string(kLeaf).find("\"layers\""), 0, "\"top_diffuse\": true, ");
  expect_flat_leaf_matches_adding_doubling(json.c_str(), 8);
}

// The stack a leaf's walk sees at a hit is the file's stack at the path's wavelength `channel`
// (materials/stack/spectral_stack.h's stack_at_wavelength, what adding-doubling solves), in
// every channel, each leaf layer with PROSPECT-D's index there; seen from below, the flipped
// file's. A skin chromophore layer over a grey layer is carried the same way.
TEST(SpectralLeaf, TheWalksStackIsTheFilesStackAtTheFollowedWavelength) {
  const SpectralStack leaf = parse_spectral_stack_json(kLeaf, "leaf");
  const SampledWavelengths w = SampledWavelengths::from_uniform(0.1);
  for (const bool below : {false, true}) {
    const SpectralStack seen = below ? flipped(leaf) : leaf;
    for (int h = 0; h < kChannels; ++h) {
      LayerStack walk;
      stack_at_wavelength_channel(seen.stack, &leaf, below, w, h, &walk);
      const LayerStack expected = stack_at_wavelength(seen, w.nm(h));
      ASSERT_EQ(walk.layers.size(), expected.layers.size());
      for (std::size_t i = 0; i < walk.layers.size(); ++i) {
        const Layer &a = walk.layers[i], &b = expected.layers[i];
        EXPECT_EQ(a.ior, b.ior) << "layer " << i << ", channel " << h << ", below " << below;
        EXPECT_EQ(a.thickness, b.thickness);
        ASSERT_EQ(a.lobes.size(), 1u);
        for (int c = 0; c < kChannels; ++c) {
          EXPECT_DOUBLE_EQ(a.sigma_a[c], b.sigma_a[0]) << "layer " << i << ", channel " << c;
          EXPECT_DOUBLE_EQ(a.lobes[0].sigma_s[c], b.lobes[0].sigma_s[0]) << "layer " << i << ", channel " << c;
          EXPECT_DOUBLE_EQ(a.lobes[0].g[c], b.lobes[0].g[0]);
        }
      }
    }
  }
  // The index differs between the path's wavelengths (so the walk must follow one).
  EXPECT_NE(LeafChromophores::refractive_index(w.nm(0)), LeafChromophores::refractive_index(w.nm(1)));
  EXPECT_TRUE(has_leaf_layers(leaf));
}

// Leaf pigment maps (docs/stack_bindings.md, "Leaf parameters"): the leaf of kLeaf written to a
// file and read as the spectral mode reads a bound material (material_binding: leaf_stack, the
// template whose leaf layers keep their contents), with `spec`'s bindings; textures resolve
// against `dir`. Returns the material and, through *spectral_layers, the file's leaf layers.
std::shared_ptr<const LayeredMaterial> bound_leaf_material(const nlohmann::json& spec, const std::filesystem::path& dir,
                                                           std::shared_ptr<const SpectralStack>* spectral_layers) {
  const std::string file = (dir / "leaf.json").string();
  std::ofstream(file) << kLeaf;
  const std::optional<StackTemplate> t = leaf_stack(file);
  EXPECT_TRUE(t.has_value());
  auto templ = std::make_shared<const StackTemplate>(*t);
  static const SceneDesc desc = make_scene({test::slab_plane(0)});
  auto b = std::make_shared<const StackBindings>(spec, templ, desc, file, "leaf", file);
  *spectral_layers = std::make_shared<const SpectralStack>(load_spectral_stack(file));
  return std::make_shared<const LayeredMaterial>(templ->stack, file, std::move(b));
}

std::filesystem::path pigment_dir() {
  const auto dir = std::filesystem::temp_directory_path() / ("lamina_leaf_maps_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  test::write_png8((dir / "grey.png").string(), 2, 2, 1, {77, 77, 77, 77});
  test::write_png8((dir / "ramp.png").string(), 2, 1, 1, {0, 255});  // t = 0 at u < 0.25, 1 at u > 0.75
  return dir;
}

// kLeaf's chlorophyll (palisade 15.936, spongy 24.064 ug/cm2) bound by constant maps to `total`,
// shared as in the file: the bindings of a leaf whose chlorophyll is `total`.
nlohmann::json constant_chlorophyll(double total) {
  const double palisade = 15.936 * total / 40.0, spongy = 24.064 * total / 40.0;
  return {{"bind",
           {{{"parameter", "layers[1].leaf.chlorophyll"}, {"texture", "grey.png"}, {"range", {palisade, palisade}}},
            {{"parameter", "layers[2].leaf.chlorophyll"}, {"texture", "grey.png"}, {"range", {spongy, spongy}}}}}};
}

// A map that holds the file's values gives the unbound leaf's image bit for bit (the same seed),
// seen from above and from below (the bound contents flipped with the layers).
TEST(SpectralLeafMaps, AConstantMapEqualsTheUnboundLeafBitForBit) {
  const auto dir = pigment_dir();
  nlohmann::json spec = constant_chlorophyll(40.0);
  spec["bind"].push_back({{"parameter", "layers[2].leaf.plates"}, {"texture", "grey.png"}, {"range", {1.5433, 1.5433}}});
  for (const bool below : {false, true}) {
    std::shared_ptr<const SpectralStack> layers;
    auto m = bound_leaf_material(spec, dir, &layers);
    const Image bound = render_material(m, layers, true, false, below, 30.0, 12, 8, 11);
    const Image unbound = render_slab(kLeaf, true, false, below, 30.0, 12, 8, 11);
    ASSERT_EQ(bound.width, unbound.width);
    int differing = 0;
    for (int y = 0; y < bound.height; ++y)
      for (int x = 0; x < bound.width; ++x)
        for (int c = 0; c < 3; ++c) differing += bound.pixel(x, y)[c] != unbound.pixel(x, y)[c] ? 1 : 0;
    EXPECT_EQ(differing, 0) << "below " << below;
  }
  std::filesystem::remove_all(dir);
}

// The map's value at a hit sets the bound layer's contents, and the walk's stack at the path's
// wavelengths is the leaf with that content: a ramp from 0 to 60 ug/cm2 in the palisade
// (layers[1]) raises its absorption at every visible wavelength, most at chlorophyll's red and
// blue bands, and leaves the spongy mesophyll (layers[2]) the file's.
TEST(SpectralLeafMaps, TheMapSetsTheBoundLayersContentsAtEachHit) {
  const auto dir = pigment_dir();
  const nlohmann::json spec = {
      {"bind", {{{"parameter", "layers[1].leaf.chlorophyll"}, {"texture", "ramp.png"}, {"range", {0.0, 60.0}}}}}};
  std::shared_ptr<const SpectralStack> layers;
  auto m = bound_leaf_material(spec, dir, &layers);
  const SpectralStack file = *layers;
  SpectralStack at_hit;
  const double wavelengths[] = {440.0, 550.0, 670.0};
  double absorption[2][3];
  for (const double u : {0.1, 0.9}) {
    bind_chromophores(file, *m->bindings(), {u, 0.5}, &at_hit);
    const double chlorophyll = u < 0.5 ? 0.0 : 60.0;
    EXPECT_EQ(at_hit.leaves[1]->contents.chlorophyll, chlorophyll) << "u " << u;
    EXPECT_EQ(at_hit.leaves[1]->contents.carotenoids, file.leaves[1]->contents.carotenoids);
    EXPECT_EQ(at_hit.leaves[2]->contents.chlorophyll, file.leaves[2]->contents.chlorophyll);
    SpectralStack edited = file;
    edited.leaves[1]->contents.chlorophyll = chlorophyll;
    // The walk's stack at each of the path's wavelengths is the edited file's there.
    const SampledWavelengths w = SampledWavelengths::from_uniform(0.3);
    for (int h = 0; h < kChannels; ++h) {
      LayerStack walk;
      stack_at_wavelength_channel(m->base_stack(), &at_hit, false, w, h, &walk);
      const LayerStack expected = stack_at_wavelength(edited, w.nm(h));
      for (int l : {1, 2}) {
        EXPECT_EQ(walk.layers[l].sigma_a[0], expected.layers[l].sigma_a[0]) << "u " << u << ", layer " << l << ", " << w.nm(h) << " nm";
        EXPECT_EQ(walk.layers[l].lobes[0].sigma_s[0], expected.layers[l].lobes[0].sigma_s[0]);
        EXPECT_EQ(walk.layers[l].ior, expected.layers[l].ior);
      }
    }
    for (int i = 0; i < 3; ++i) absorption[u < 0.5 ? 0 : 1][i] = stack_at_wavelength(edited, wavelengths[i]).layers[1].sigma_a[0];
  }
  for (int i = 0; i < 3; ++i) EXPECT_GT(absorption[1][i], absorption[0][i]) << wavelengths[i] << " nm";
  // Chlorophyll absorbs in the red and the blue, little in the green.
  EXPECT_GT(absorption[1][2] - absorption[0][2], 3.0 * (absorption[1][1] - absorption[0][1]));
  EXPECT_GT(absorption[1][0] - absorption[0][0], 3.0 * (absorption[1][1] - absorption[0][1]));
  std::filesystem::remove_all(dir);
}

// Rendered: a leaf whose chlorophyll comes from a map equals, within 3 standard errors (plus the
// solver's and the grid's errors), adding-doubling of the file with that chlorophyll; more
// chlorophyll is darker in the red and the green. (Linear Rec. 709's blue of a leaf's reflectance
// rises with chlorophyll although the leaf reflects less at every blue wavelength: the blue
// channel's colour-matching function is negative in the green, which chlorophyll darkens.)
TEST(SpectralLeafMaps, ChlorophyllMapsRenderAsTheLeafWithThatChlorophyll) {
  const auto dir = pigment_dir();
  const double theta = 30.0, mu = std::cos(theta * kPi / 180.0);
  ImageStats rendered[2];
  const double totals[] = {8.0, 80.0};
  for (int k = 0; k < 2; ++k) {
    std::shared_ptr<const SpectralStack> layers;
    auto m = bound_leaf_material(constant_chlorophyll(totals[k]), dir, &layers);
    rendered[k] = stats_of(render_material(m, layers, true, false, false, theta, 24, 32, 13 + k));
    SpectralStack edited = *layers;
    edited.leaves[1]->contents.chlorophyll = 15.936 * totals[k] / 40.0;
    edited.leaves[2]->contents.chlorophyll = 24.064 * totals[k] / 40.0;
    Spectrum expected;
    const Spectrum tol = adding_doubling_tolerance(edited, mu, false, rendered[k], &expected);
    for (int c = 0; c < 3; ++c) {
      if (verbose())
        std::printf("chlorophyll %g, channel %d: rendered %g +- %g, adding-doubling %g (tolerance %g)\n", totals[k], c,
                    rendered[k].mean[c], rendered[k].stderr_[c], expected[c], tol[c]);
      EXPECT_NEAR(rendered[k].mean[c], expected[c], tol[c]) << "chlorophyll " << totals[k] << ", channel " << c;
    }
  }
  for (int c = 0; c < 2; ++c)
    EXPECT_LT(rendered[1].mean[c] + 3.0 * std::hypot(rendered[0].stderr_[c], rendered[1].stderr_[c]), rendered[0].mean[c])
        << "channel " << c;
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace lamina
