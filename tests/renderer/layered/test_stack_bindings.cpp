// Texture-driven stack parameters: maps are read as data, bindings map channels through their
// range into the stack, freckles follow their Poisson intensity (Campbell's theorem), and the
// demo scenes (head_skin, leaves) load, bind and find their maps.
#include "renderer/layered/stack_bindings.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "tests/support/image_files.h"
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "materials/adding_doubling/adding_doubling.h"
#include "materials/base/sampling.h"
#include "materials/tables/albedo.h"
#include "materials/stack/stack_file.h"
#include "renderer/image/image_io.h"
#include "renderer/layered/layered_material.h"
#include "renderer/scene/scene_gltf.h"
#include "renderer/layered/material_binding.h"
#include "renderer/layered/layered_tables.h"
#include "renderer/surfaces/table_surface.h"
#include "materials/tables/layered_table.h"

namespace lamina {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

std::string source(const std::string& rel) { return std::string(LAMINA_SOURCE_DIR) + "/" + rel; }

fs::path temp_dir(const std::string& name) {
  const fs::path d = fs::temp_directory_path() / ("lamina_test_stack_bindings_" + name);
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

// A 4 x 1 grey 8-bit PNG with stored values 0, 64, 128, 255 (no colour transform on write).
std::string write_ramp_png(const fs::path& dir, int channels = 1) {
  const std::string path = (dir / "ramp.png").string();
  const unsigned char v[4] = {0, 64, 128, 255};
  std::vector<unsigned char> px;
  for (int i = 0; i < 4; ++i)
    for (int c = 0; c < channels; ++c) px.push_back(c == 0 ? v[i] : static_cast<unsigned char>(255 - v[i]));
  test::write_png8(path, 4, 1, channels, px);  // the values as given (no premultiplication)
  return path;
}

TEST(ParameterMap, ReadsStoredValuesWithoutSrgbDecoding) {
  const fs::path dir = temp_dir("ramp");
  const ParameterMap m = read_parameter_map(write_ramp_png(dir));
  ASSERT_EQ(m.width, 4);
  ASSERT_EQ(m.channels, 1);
  // Texel centres at (i + 0.5) / 4: the stored value / 255 exactly (sRGB decoding would give
  // 0.0513 for 64).
  EXPECT_NEAR(m.lookup({0.125, 0.5}, 0), 0.0, 1e-7);
  EXPECT_NEAR(m.lookup({0.375, 0.5}, 0), 64.0 / 255.0, 1e-7);
  EXPECT_NEAR(m.lookup({0.625, 0.5}, 0), 128.0 / 255.0, 1e-7);
  EXPECT_NEAR(m.lookup({0.875, 0.5}, 0), 1.0, 1e-7);
  // Bilinear halfway between texels 1 and 2; clamped outside [0, 1].
  EXPECT_NEAR(m.lookup({0.5, 0.5}, 0), 96.0 / 255.0, 1e-7);
  EXPECT_NEAR(m.lookup({-3.0, 0.5}, 0), 0.0, 1e-7);
  EXPECT_THROW(read_parameter_map((dir / "missing.png").string()), SceneError);
}

TEST(Freckles, MeanFollowsTheIntensityAndTheProfileIntegral) {
  // Over the unit torus every spot contributes its whole profile integral I (the cut at 3r is
  // within a cell), so the UV mean is sum_k a_k I / 1 with K ~ Poisson(density) spots:
  // E = density E[a] I, Var = density E[a^2] I^2 (Campbell), E[a] = 0.75 A,
  // E[a^2] = A^2 E[(0.5 + 0.5 U)^2] = (7/12) A^2.
  const double density = 500.0, radius = 0.01, amplitude = 1.0;
  const int seeds = 10;
  const double integral = freckle_profile_integral(radius);
  // The quadrature of the grid (spacing r/5, midpoints) is exact to ~1e-4 relative for this
  // smooth, periodic field; small against the statistical error below.
  const int n = static_cast<int>(std::round(5.0 / radius));
  double sum = 0.0;
  for (int s = 0; s < seeds; ++s) {
    Freckles f;
    f.density = density;
    f.radius = radius;
    f.amplitude = amplitude;
    f.seed = 100 + s;
    f.prepare();
    double mean = 0.0;
    for (int y = 0; y < n; ++y)
      for (int x = 0; x < n; ++x) mean += f.value({(x + 0.5) / n, (y + 0.5) / n});
    sum += mean / (static_cast<double>(n) * n);
  }
  const double estimate = sum / seeds;
  const double expected = density * 0.75 * amplitude * integral;
  const double sigma = std::sqrt(density * (7.0 / 12.0) * amplitude * amplitude * integral * integral / seeds);
  EXPECT_NEAR(estimate, expected, 4.0 * sigma) << "expected " << expected << ", sigma " << sigma;
}

// prepare() draws every cell's spots once into a table; without one (prepare(0), what radii too
// small to tabulate get) value() draws the nine cells' spots per call. Both must give the same
// field bit for bit, at the seams too.
TEST(Freckles, TabulatedSpotsAreTheDrawnOnes) {
  struct Config {
    double density, radius;
  };
  for (const Config c : {Config{2500.0, 0.004}, Config{50.0, 0.05}, Config{3.0, 1.0 / 6.0}, Config{20000.0, 0.003}}) {
    Freckles table, drawn;
    for (Freckles* f : {&table, &drawn}) {
      f->density = c.density;
      f->radius = c.radius;
      f->amplitude = 0.4;
      f->seed = 11;
    }
    table.prepare();
    drawn.prepare(0.0);
    ASSERT_TRUE(table.tabulated());
    ASSERT_FALSE(drawn.tabulated());
    int nonzero = 0;
    for (int i = 0; i < 20000; ++i) {
      // Quasi-random points, and every tenth one on a seam of the unit square.
      glm::dvec2 uv((i * 0.618034) - std::floor(i * 0.618034), (i * 0.414214) - std::floor(i * 0.414214));
      if (i % 10 == 0) uv.x = (i % 20 == 0) ? 0.0 : 1.0 - 1e-12;
      const double v = table.value(uv);
      ASSERT_EQ(v, drawn.value(uv)) << "density " << c.density << " radius " << c.radius << " at " << uv.x << ", " << uv.y;
      nonzero += v != 0.0;
    }
    EXPECT_GT(nonzero, 100) << "density " << c.density;  // the comparison saw spots
  }
}

TEST(Freckles, ProfileIntegralMatchesQuadrature) {
  // Independent check of the closed form: midpoint rule in d on [0, 3r].
  const double r = 0.02, c = std::exp(-4.5);
  double q = 0.0;
  const int n = 200000;
  for (int i = 0; i < n; ++i) {
    const double d = (i + 0.5) * 3.0 * r / n;
    q += (std::exp(-d * d / (2 * r * r)) - c) / (1 - c) * 2 * 3.14159265358979323846 * d * (3.0 * r / n);
  }
  EXPECT_NEAR(freckle_profile_integral(r), q, 1e-9);
}

TEST(Freckles, PeriodicDeterministicBoundedAndContinuous) {
  Freckles f;
  f.density = 500.0;
  f.radius = 0.02;
  f.amplitude = 0.3;
  f.seed = 9;
  f.prepare();
  double max_value = 0.0;
  for (int i = 0; i < 2000; ++i) {
    const glm::dvec2 uv((i * 0.618034) - std::floor(i * 0.618034), (i * 0.414214) - std::floor(i * 0.414214));
    const double v = f.value(uv);
    EXPECT_EQ(v, f.value(uv));                                     // deterministic
    EXPECT_NEAR(v, f.value(uv + glm::dvec2(1.0, -2.0)), 1e-12);    // periodic in u and v
    EXPECT_GE(v, 0.0);
    max_value = std::max(max_value, v);
    // Continuous: a step of 1e-6 UV changes the field by at most |grad| 1e-6; the steepest
    // slope of one spot is A / (r sqrt(e)) / (1 - e^-4.5), times a few overlapping spots.
    EXPECT_NEAR(f.value(uv + glm::dvec2(1e-6, 0.0)), v, 10.0 * 0.3 / 0.02 * 1e-6);
  }
  EXPECT_GT(max_value, 0.1);  // there are spots
  f.density = 0.0;
  EXPECT_EQ(f.value({0.3, 0.3}), 0.0);
  Freckles bad;
  bad.radius = 0.2;
  EXPECT_THROW(bad.prepare(), std::invalid_argument);
  bad.radius = 0.001;
  bad.density = 1e8;
  EXPECT_THROW(bad.prepare(), std::invalid_argument);
  EXPECT_EQ(f.value({std::nan(""), 0.5}), 0.0);
}

// A minimal SceneDesc for bindings that name files only.
SceneDesc empty_scene() {
  SceneDesc s;
  s.path = "scene.gltf";
  return s;
}

TEST(StackBindings, ChannelThroughRangeIntoTheStack) {
  const fs::path dir = temp_dir("range");
  write_ramp_png(dir, 2);  // grey + alpha (alpha = 255 - grey)
  auto t = std::make_shared<const StackTemplate>(load_stack_template(source("scenes/materials/skin_oily.json")));
  const SceneDesc scene = empty_scene();
  const json spec = json::parse(R"({"bind": [
      {"parameter": "layers[2].components[0].fraction", "texture": "ramp.png", "channel": "r", "range": [0.005, 0.05]},
      {"parameter": "layers[0].thickness", "texture": "ramp.png", "channel": "a", "range": [0.01, 0.0]}]})");
  const StackBindings b(spec, t, scene, (dir / "map.json").string(), "skin", (dir / "map.json").string());
  ASSERT_EQ(b.parameters().size(), 2u);
  Spectrum v[2];
  b.values({0.375, 0.5}, v);
  EXPECT_NEAR(v[0][0], 0.005 + 0.045 * 64.0 / 255.0, 1e-7);
  EXPECT_NEAR(v[1][0], 0.01 * (64.0 / 255.0), 1e-9);  // inverted range, alpha = 1 - 64/255
  LayerStack got, expected;
  b.evaluate({0.375, 0.5}, &got);
  apply_parameters(*t, b.parameters(), v, &expected);
  EXPECT_EQ(got.layers[2].sigma_a, expected.layers[2].sigma_a);
  EXPECT_EQ(got.layers[0].thickness, expected.layers[0].thickness);
  EXPECT_EQ(validate_stack(got), "");
}

// map_nodes: the ends are the smallest and largest texel values, a constant map gives one node, a
// map of two values two nodes (every texel on a node: nothing to gain from a third), and the
// nodes are increasing and the same on every call.
TEST(MapNodes, EndsAtTheTexelsAndIncreasing) {
  EXPECT_EQ(map_nodes({0.3, 0.3, 0.3}, 5), std::vector<double>({0.3}));
  EXPECT_EQ(map_nodes({0.2, 0.7, 0.2, 0.7}, 5), std::vector<double>({0.2, 0.7}));
  Rng rng(5, 0);
  std::vector<double> t;
  for (int i = 0; i < 10000; ++i) t.push_back(0.1 + 0.6 * rng.uniform() * rng.uniform());
  const std::vector<double> n = map_nodes(t, 5);
  ASSERT_EQ(n.size(), 5u);
  EXPECT_EQ(n.front(), *std::min_element(t.begin(), t.end()));
  EXPECT_EQ(n.back(), *std::max_element(t.begin(), t.end()));
  for (std::size_t i = 1; i < n.size(); ++i) EXPECT_LT(n[i - 1], n[i]);
  EXPECT_EQ(map_nodes(t, 5), n);
}

// Why the nodes follow the texels: a face's melanin map is mostly near 0 with a few dark texels
// far above (eyebrows), and a layer's albedo falls steeply, convexly, with melanin. Linear
// interpolation of such a response, exp(-20 t), between map_nodes' five nodes errs over the
// texels at most a third as much as between five nodes evenly over the range (measured 14x
// less on this map).
TEST(MapNodes, InterpolateASkewedMapBetterThanEvenNodes) {
  Rng rng(11, 0);
  std::vector<double> t;
  for (int i = 0; i < 20000; ++i) {
    const double u = rng.uniform();
    t.push_back(i % 100 == 0 ? 0.5 + 0.5 * u : 0.05 * u * u);  // 1 % eyebrows, the rest light skin
  }
  auto f = [](double x) { return std::exp(-20.0 * x); };
  auto mean_error = [&](const std::vector<double>& nodes) {
    double sum = 0.0;
    for (double x : t) {
      std::size_t j = 1;
      while (j + 1 < nodes.size() && nodes[j] < x) ++j;
      const double a = nodes[j - 1], b = nodes[j], w = std::clamp((x - a) / (b - a), 0.0, 1.0);
      sum += std::abs((1 - w) * f(a) + w * f(b) - f(x));
    }
    return sum / static_cast<double>(t.size());
  };
  const double lo = *std::min_element(t.begin(), t.end()), hi = *std::max_element(t.begin(), t.end());
  std::vector<double> even;
  for (int j = 0; j < 5; ++j) even.push_back(lo + (hi - lo) * j / 4.0);
  const double e_map = mean_error(map_nodes(t, 5)), e_even = mean_error(even);
  std::printf("mean interpolation error: map_nodes %.3g, even %.3g (%.1fx)\n", e_map, e_even, e_even / e_map);
  EXPECT_LT(3.0 * e_map, e_even);
}

// The lambert mode follows texture-driven parameters (LayeredMaterial::lambert_albedo_at): with
// one bound parameter its albedo at a point equals the walk's albedo of the stack there (exact
// at the model's nodes, linear between them), within the estimates' standard errors: at the
// ramp's texels (blood 0, 0.020, 0.040, 0.08; nodes every 0.02).
TEST(StackBindings, LambertAlbedoFollowsTheBoundParameter) {
  const fs::path dir = temp_dir("lambert-at");
  write_ramp_png(dir);
  auto t = std::make_shared<const StackTemplate>(load_stack_template(source("scenes/materials/skin.json")));
  const SceneDesc scene = empty_scene();
  const json spec = json::parse(R"({"bind": [
      {"parameter": "layers[1].components[0].fraction", "texture": "ramp.png", "channel": "r", "range": [0.0, 0.08]}]})");
  auto b = std::make_shared<const StackBindings>(spec, t, scene, (dir / "map.json").string(), "skin", (dir / "map.json").string());
  const LayeredMaterial m(t->stack, "skin.json", b);
  Spectrum previous_green(2.0);
  for (double u : {0.125, 0.375, 0.625, 0.875}) {
    StackScratch scratch;
    ShadingPoint sp;
    sp.uv = {u, 0.5};
    Spectrum se;
    const Spectrum walk = diffuse_bihemispherical_albedo(m.stack_at(sp, scratch), LayeredMaterial::kDefaultAlbedoWalks, 77, &se);
    const Spectrum model = m.lambert_albedo_at(sp.uv);
    for (int c = 0; c < kChannels; ++c) {
      // The model's own noise: its base albedo's error, and its node ratios' (about as large).
      const double tolerance = 4.0 * std::sqrt(se[c] * se[c] + 3.0 * m.lambert_albedo_stderr()[c] * m.lambert_albedo_stderr()[c]);
      EXPECT_NEAR(model[c], walk[c], tolerance) << "u " << u << " channel " << c;
    }
    EXPECT_LT(model[1], previous_green[1]);  // more blood: less green
    previous_green = model;
  }
}

// The table mode follows texture-driven parameters (renderer/layered/layered_tables.h). One bound
// parameter (dermal blood over [0, 0.08], 5 nodes): at every texel of the ramp the scaled table
// equals, bin for bin, the interpolation in ln T of the tables built for the stacks at the two
// nodes around the texel's value (exact algebra: T_0 (T_lo / T_0)^(1 - t) (T_hi / T_0)^t), and
// at the ramp's ends (nodes 0 and 4) the table of the hit's own stack. Two bound parameters
// (blood and epidermal melanin, both driven by the grey channel: "g" of a grey map is its grey,
// so they share one axis): the model against the table of the hit's stack is closer than the
// base table, at every texel where they differ.
TEST(StackBindings, TableFollowsTheBoundParameters) {
  const fs::path dir = temp_dir("table-at");
  write_ramp_png(dir, 2);
  auto t = std::make_shared<const StackTemplate>(load_stack_template(source("scenes/materials/skin.json")));
  const SceneDesc scene = empty_scene();
  TableSettings ts;  // adding-doubling: no noise, so the comparisons can be exact
  const glm::dvec3 wo = glm::normalize(glm::dvec3(0.3, 0.1, 0.8));
  std::vector<glm::dvec3> wis;
  for (double theta : {10.0, 35.0, 60.0, 80.0})
    for (double phi : {0.0, 100.0, 200.0}) {
      const double th = theta * kPi / 180.0, ph = phi * kPi / 180.0;
      wis.push_back({std::sin(th) * std::cos(ph), std::sin(th) * std::sin(ph), std::cos(th)});
    }
  auto eval_all = [&](const TableSurface& s) {
    std::vector<Spectrum> f;
    for (const glm::dvec3& wi : wis) f.push_back(s.eval(wo, wi));
    return f;
  };
  for (int parameters : {1, 2}) {
    const json spec = json::parse(parameters == 1 ? R"({"bind": [
        {"parameter": "layers[1].components[0].fraction", "texture": "ramp.png", "channel": "r", "range": [0.0, 0.08]}]})"
                                                  : R"({"bind": [
        {"parameter": "layers[1].components[0].fraction", "texture": "ramp.png", "channel": "r", "range": [0.0, 0.08]},
        {"parameter": "layers[0].components[0].fraction", "texture": "ramp.png", "channel": "g", "range": [0.01, 0.2]}]})");
    auto b = std::make_shared<const StackBindings>(spec, t, scene, (dir / "map.json").string(), "skin", (dir / "map.json").string());
    LayeredBindings bindings;
    bindings.by_material.push_back(std::make_shared<const LayeredMaterial>(t->stack, "skin.json", b));
    const LayeredMaterial* m = bindings.by_material[0].get();
    const LayeredTables tables(bindings, ts);
    // One map channel drives both: one axis (renderer/layered/layered_tables.h).
    EXPECT_EQ(tables.parameter_tables(), LayeredTables::kParameterNodes);
    const LayeredTable& base = tables.get(m, false);
    for (double u : {0.125, 0.375, 0.625, 0.875}) {
      StackScratch scratch;
      ShadingPoint sp;
      sp.uv = {u, 0.5};
      const LayerStack& hit_stack = m->stack_at(sp, scratch);
      Spectrum values[2];
      b->values(sp.uv, values);
      TableFactor factors[LayeredTables::kMaxFactors];
      const int n = tables.factors(m, false, values, factors);
      ASSERT_EQ(n, 1);
      const std::vector<Spectrum> model = eval_all(TableSurface(base, hit_stack, wo, factors, n));
      const LayeredTable own = build_layered_table(hit_stack, ts);
      const std::vector<Spectrum> truth = eval_all(TableSurface(own, hit_stack, wo, nullptr, 0));
      if (parameters == 1) {
        // Between nodes, per incidence node and bin, the interpolation of ln T (layered_tables.h):
        // T_0 (lo / T_0)^(1 - t) (hi / T_0)^t = lo^(1 - t) hi^t.
        for (int node = 0; node < ts.nodes; ++node)
          for (int bin = 0; bin < base.bins(); ++bin) {
            const Spectrum f = table_model_value(base, factors, n, node, bin);
            const Spectrum lo = factors[0].lo->at(node, bin), hi = factors[0].hi->at(node, bin);
            for (int c = 0; c < kChannels; ++c) {
              if (!(lo[c] > 1e-12 * base.power[node] && hi[c] > 1e-12 * base.power[node])) continue;
              const double interpolated = std::pow(lo[c], 1.0 - factors[0].t) * std::pow(hi[c], factors[0].t);
              EXPECT_NEAR(f[c], interpolated, 1e-9 * interpolated) << "u " << u << " node " << node << " bin " << bin;
            }
          }
        const bool on_node = u < 0.25 || u > 0.75;
        for (std::size_t i = 0; i < wis.size(); ++i)
          for (int c = 0; c < kChannels; ++c) {
            if (on_node) {
              EXPECT_NEAR(model[i][c], truth[i][c], 1e-9 * truth[i][c] + 1e-15) << "u " << u << " direction " << i;
            }
          }
      } else {
        const std::vector<Spectrum> old = eval_all(TableSurface(base, hit_stack, wo, nullptr, 0));
        double err_model = 0.0, err_base = 0.0;
        for (std::size_t i = 0; i < wis.size(); ++i)
          for (int c = 0; c < kChannels; ++c) {
            err_model += std::abs(model[i][c] - truth[i][c]);
            err_base += std::abs(old[i][c] - truth[i][c]);
          }
        std::printf("two parameters, u %.3f: sum |model - truth| %.4g, |base table - truth| %.4g\n", u, err_model, err_base);
        EXPECT_LT(err_model, err_base) << "u " << u;
      }
    }
  }
}

// A transmitting stack (the leaf, pigment bound): the tables along the parameter exist for both
// sides, and seen from below at a node the model is the table of the hit's flipped stack.
// (Regression: the second side's nodes were copied from the first after it had been moved.)
TEST(StackBindings, TableFollowsTheBoundParametersFromBothSides) {
  const fs::path dir = temp_dir("table-both-sides");
  write_ramp_png(dir, 2);
  auto t = std::make_shared<const StackTemplate>(load_stack_template(source("scenes/materials/leaf.json")));
  const SceneDesc scene = empty_scene();
  const json spec = json::parse(R"({"bind": [
      {"parameter": "layers[1].components[0].fraction", "texture": "ramp.png", "channel": "r", "range": [0.1, 0.5]}]})");
  auto b = std::make_shared<const StackBindings>(spec, t, scene, (dir / "map.json").string(), "leaf", (dir / "map.json").string());
  LayeredBindings bindings;
  bindings.by_material.push_back(std::make_shared<const LayeredMaterial>(t->stack, "leaf.json", b));
  const LayeredMaterial* m = bindings.by_material[0].get();
  ASSERT_TRUE(m->transmits());
  const LayeredTables tables(bindings, TableSettings{});
  EXPECT_EQ(tables.parameter_tables(), 2 * LayeredTables::kParameterNodes);
  const glm::dvec3 wo = glm::normalize(glm::dvec3(0.2, -0.1, 0.9));
  const glm::dvec3 wi = glm::normalize(glm::dvec3(-0.3, 0.2, 0.7));
  for (double u : {0.125, 0.875}) {  // the ramp's ends: nodes 0 and 4
    StackScratch scratch;
    ShadingPoint sp;
    sp.uv = {u, 0.5};
    const LayerStack below = flipped(m->stack_at(sp, scratch));
    Spectrum values[1];
    b->values(sp.uv, values);
    TableFactor factors[LayeredTables::kMaxFactors];
    for (bool from_below : {false, true}) {
      const int n = tables.factors(m, from_below, values, factors);
      ASSERT_EQ(n, 1) << "from below " << from_below;
      ASSERT_TRUE(factors[0].lo && factors[0].hi);
    }
    const Spectrum model = TableSurface(tables.get(m, true), below, wo, factors, 1).eval(wo, wi);
    const Spectrum truth = TableSurface(build_layered_table(below, TableSettings{}), below, wo, nullptr, 0).eval(wo, wi);
    for (int c = 0; c < kChannels; ++c) EXPECT_NEAR(model[c], truth[c], 1e-9 * truth[c] + 1e-15) << "u " << u << " channel " << c;
  }
}

// Physiological maps: a melanin map and a blood map bound to a chromophore skin's epidermis and
// dermis. Constant maps (range [v, v]) give, bit for bit, the stack of the file with those values
// (the baseline giving way by the difference, docs/stack_bindings.md), at every point; the table
// and lambert modes see the same stack (the table of the hit's stack; the lambert albedo of the
// file's stack). A ramp darkens the skin with melanin in every channel.
TEST(StackBindings, ConstantMelaninAndBloodMapsGiveTheFileWithThoseValues) {
  const fs::path dir = temp_dir("chromophores");
  test::write_png8((dir / "grey.png").string(), 2, 2, 1, {77, 77, 77, 77});
  write_ramp_png(dir);
  const std::string text = [] {
    std::ifstream in(source("scenes/spectral/skin_spectral.json"));
    std::ostringstream ss;
    ss << in.rdbuf();
    return ss.str();
  }();
  auto t = std::make_shared<const StackTemplate>(parse_stack_template_json(text, "skin_spectral.json"));
  const SceneDesc scene = empty_scene();
  const double melanin = 0.12, blood = 0.035;
  json spec = json::parse(R"({"bind": [
      {"parameter": "layers[0].chromophores.melanin", "texture": "grey.png", "channel": "r", "range": [0, 0]},
      {"parameter": "layers[1].chromophores.blood", "texture": "grey.png", "channel": "r", "range": [0, 0]}]})");
  spec["bind"][0]["range"] = {melanin, melanin};
  spec["bind"][1]["range"] = {blood, blood};
  auto b = std::make_shared<const StackBindings>(spec, t, scene, (dir / "map.json").string(), "skin", (dir / "map.json").string());
  json edited = json::parse(text);
  edited["layers"][0]["chromophores"]["melanin"] = melanin;
  edited["layers"][0]["chromophores"]["baseline"] = 0.97 - (melanin - 0.03);
  edited["layers"][1]["chromophores"]["blood"] = blood;
  edited["layers"][1]["chromophores"]["baseline"] = 0.38 - (blood - 0.02);
  const LayerStack expected = parse_stack_json(edited.dump(), "edited");
  const LayeredMaterial bound(t->stack, "skin_spectral.json", b);
  const LayeredMaterial unbound(expected, "edited");
  for (double u : {0.1, 0.5, 0.9}) {
    StackScratch scratch;
    ShadingPoint sp;
    sp.uv = {u, 1.0 - u};
    const LayerStack& got = bound.stack_at(sp, scratch);
    for (std::size_t i = 0; i < 2; ++i) {
      EXPECT_EQ(got.layers[i].sigma_a, expected.layers[i].sigma_a) << "u " << u << " layer " << i;
      EXPECT_EQ(got.layers[i].lobes[0].sigma_s, expected.layers[i].lobes[0].sigma_s);
    }
    // The lambert model: the template's albedo times that of the constant values over the
    // template's (adding-doubling: no noise), so the file's albedo to rounding.
    const Spectrum model = bound.lambert_albedo_at(sp.uv), own = unbound.lambert_albedo_at(sp.uv);
    for (int c = 0; c < kChannels; ++c) EXPECT_NEAR(model[c], own[c], 1e-12) << "u " << u << " channel " << c;
  }
  LayeredBindings bindings;
  bindings.by_material.push_back(std::make_shared<const LayeredMaterial>(t->stack, "skin_spectral.json", b));
  const LayeredMaterial* m = bindings.by_material[0].get();
  const LayeredTables tables(bindings, TableSettings{});
  Spectrum values[2];
  b->values({0.5, 0.5}, values);
  TableFactor factors[LayeredTables::kMaxFactors];
  const int n = tables.factors(m, false, values, factors);
  const glm::dvec3 wo = glm::normalize(glm::dvec3(0.2, -0.1, 0.9)), wi = glm::normalize(glm::dvec3(-0.3, 0.2, 0.7));
  const Spectrum model = TableSurface(tables.get(m, false), expected, wo, factors, n).eval(wo, wi);
  const Spectrum truth = TableSurface(build_layered_table(expected, TableSettings{}), expected, wo, nullptr, 0).eval(wo, wi);
  EXPECT_EQ(n, 0);  // constant maps: no axes, the base table is the file's
  EXPECT_EQ(model, truth);

  const json ramp = json::parse(R"({"bind": [
      {"parameter": "layers[0].chromophores.melanin", "texture": "ramp.png", "channel": "r", "range": [0.01, 0.4]}]})");
  const StackBindings r(ramp, t, scene, (dir / "map.json").string(), "skin", (dir / "map.json").string());
  Spectrum previous(2.0);
  for (double u : {0.125, 0.375, 0.625, 0.875}) {
    LayerStack s;
    r.evaluate({u, 0.5}, &s);
    const AddingDoublingTotals totals = adding_doubling_totals(s, 1.0);
    for (int c = 0; c < kChannels; ++c) EXPECT_LT(totals.R_diffuse[c], previous[c]) << "u " << u << " channel " << c;
    previous = totals.R_diffuse;
  }
}

TEST(StackBindings, GltfTexturesAreReencodedToTheirStoredValues) {
  SceneDesc scene = empty_scene();
  Texture tex;
  tex.width = 2;
  tex.height = 1;
  for (int k : {10, 200})
    for (int c = 0; c < 3; ++c) tex.rgb.push_back(static_cast<float>(srgb_decode(k / 255.0)));
  scene.textures.push_back(tex);
  scene.gltf_textures[3] = 0;
  auto t = std::make_shared<const StackTemplate>(load_stack_template(source("scenes/materials/skin.json")));
  const json spec = json::parse(R"({"bind": [{"parameter": "layers[1].components[0].fraction", "texture": 3,
                                              "channel": "luminance", "range": [0, 1]}]})");
  const StackBindings b(spec, t, scene, "scene.gltf", "skin", "scene.gltf");
  Spectrum v[1];
  b.values({0.25, 0.5}, v);
  EXPECT_NEAR(v[0][0], 10.0 / 255.0, 1e-6);
  b.values({0.75, 0.5}, v);
  EXPECT_NEAR(v[0][0], 200.0 / 255.0, 1e-6);
}

void expect_binding_error(const std::string& spec_text, const std::string& what) {
  const fs::path dir = temp_dir("errors");
  write_ramp_png(dir);
  auto t = std::make_shared<const StackTemplate>(load_stack_template(source("scenes/materials/skin_oily.json")));
  const SceneDesc scene = empty_scene();
  try {
    StackBindings b(json::parse(spec_text), t, scene, "map.json", "skin", (dir / "map.json").string());
    ADD_FAILURE() << "accepted " << spec_text;
  } catch (const SceneError& e) {
    const std::string m = e.what();
    EXPECT_EQ(m.rfind("map.json: material 'skin': ", 0), 0u) << m;
    EXPECT_NE(m.find(what), std::string::npos) << m;
    EXPECT_EQ(m.find('\n'), std::string::npos) << m;
  }
}

TEST(StackBindings, BadBindingsAreRejectedWithTheirPlace) {
  expect_binding_error(R"({"bind": [{"parameter": "layers[9].thickness", "texture": "ramp.png", "range": [0, 1]}]})",
                       "bind[0].parameter: layers[9].thickness: the stack has 3 layer(s)");
  expect_binding_error(R"({"bind": [{"parameter": "layers[0].thickness", "texture": "nope.png", "range": [0, 1]}]})",
                       "bind[0].texture: file 'nope.png' not found");
  expect_binding_error(R"({"bind": [{"parameter": "layers[1].components[0].fraction", "texture": "ramp.png",
                                     "range": [0, 2]}]})",
                       "bind[0].range[1]: outside the range");
  expect_binding_error(R"({"bind": [{"parameter": "layers[0].thickness", "texture": "ramp.png", "channel": "a",
                                     "range": [0, 1]}]})",
                       "bind[0].channel: the map has no alpha channel");
  expect_binding_error(R"({"bind": [{"parameter": "layers[0].thickness", "texture": "ramp.png", "channel": "rgb",
                                     "range": [0, 1]}]})",
                       "bind[0].channel: 'rgb'");
  expect_binding_error(R"({"bind": [{"parameter": "layers[0].thickness", "texture": 0, "range": [0, 1]}]})",
                       "bind[0].texture: glTF texture 0 does not exist");
  expect_binding_error(R"({"bind": [{"parameter": "layers[0].thickness", "texture": "ramp.png", "range": [0, 1],
                                     "chanel": "r"}]})",
                       "bind[0].chanel: unknown key");
  expect_binding_error(R"({"bind": [
      {"parameter": "layers[1].components[0].fraction", "texture": "ramp.png", "range": [0, 1]},
      {"parameter": "layers[1].components[1].fraction", "texture": "ramp.png", "range": [0, 1]}]})",
                       "only one fraction per layer");
  expect_binding_error(R"({"freckles": {"parameter": "layers[1].components[0].fraction", "density": 10,
                                         "radius": 0.5, "amplitude": 0.1}})",
                       "freckles: radius must lie in (0, 1/6]");
  expect_binding_error(R"({"freckles": {"parameter": "layers[1].components[0].fraction", "radius": 0.01,
                                         "amplitude": 0.1}})",
                       "freckles.density: missing");
}

TEST(StackBindings, FrecklesAddToTheBoundOrTheTemplateValue) {
  auto t = std::make_shared<const StackTemplate>(load_stack_template(source("scenes/materials/skin.json")));
  const SceneDesc scene = empty_scene();
  const json spec = json::parse(R"({"freckles": {"parameter": "layers[0].components[0].fraction",
      "density": 800, "radius": 0.01, "amplitude": 0.05, "seed": 3}})");
  const StackBindings b(spec, t, scene, "scene.gltf", "skin", "scene.gltf");
  Freckles f;
  f.density = 800;
  f.radius = 0.01;
  f.amplitude = 0.05;
  f.seed = 3;
  f.prepare();
  for (double u : {0.1, 0.37, 0.52, 0.9}) {
    Spectrum v[1];
    b.values({u, 0.4}, v);
    EXPECT_NEAR(v[0][0], 0.02 + f.value({u, 0.4}), 1e-15);
  }
}

// The demo scenes load, their layered material binds, every map exists, and the maps vary the
// parameters (so the renders are driven by them).
struct Varies {
  std::string parameter;
  glm::dvec2 a, b;
};

void check_scene(const std::string& rel, int expected_maps, const std::vector<Varies>& varies) {
  SCOPED_TRACE(rel);
  const SceneDesc desc = load_gltf(source(rel));
  const LayeredBindings bound = bind_layered_materials(desc, "");
  ASSERT_EQ(bound.count(), 1);
  const LayeredMaterial* m = bound.get(0);
  ASSERT_NE(m, nullptr);
  ASSERT_NE(m->bindings(), nullptr);
  EXPECT_EQ(static_cast<int>(m->bindings()->map_files().size()), expected_maps);
  for (const std::string& f : m->bindings()->map_files()) EXPECT_TRUE(fs::is_regular_file(f)) << f;
  for (const Varies& v : varies) {
    int k = -1;
    for (std::size_t i = 0; i < m->bindings()->parameters().size(); ++i)
      if (m->bindings()->parameters()[i].path == v.parameter) k = static_cast<int>(i);
    ASSERT_GE(k, 0) << v.parameter;
    std::vector<Spectrum> va(m->bindings()->parameters().size()), vb(va.size());
    m->bindings()->values(v.a, va.data());
    m->bindings()->values(v.b, vb.data());
    EXPECT_GT(std::abs(va[k][0] - vb[k][0]), 1e-3) << v.parameter << " does not vary between the two points";
  }
  StackScratch scratch;
  ShadingPoint sp;
  sp.uv = varies.front().a;
  EXPECT_EQ(validate_stack(m->stack_at(sp, scratch)), "");
  sp.from_below = m->transmits();
  EXPECT_EQ(validate_stack(m->stack_at(sp, scratch)), "");
}

TEST(DemoScenes, HeadSkinBindsItsFittedMaps) {
  // The maps fitted to the asset's photographs: an eyebrow (more melanin) against a cheek; the
  // lips (more blood) against the scalp; the specular map's bright forehead against a cheek for
  // oil, which drives the sebum's index and the surface roughness (4 bindings, no freckles).
  check_scene("scenes/head_skin/head_skin.gltf", 4,
              {{"layers[1].components[0].fraction", {0.42, 0.245}, {0.4, 0.38}},
               {"layers[2].components[0].fraction", {0.5, 0.47}, {0.5, 0.03}},
               {"layers[0].ior", {0.5, 0.15}, {0.3, 0.45}},
               {"roughness", {0.5, 0.15}, {0.3, 0.45}}});
}

TEST(DemoScenes, ProceduralHeadSkinBindsBloodOilAndFreckles) {
  // Lips (red: more blood) against the scalp; the T-zone (forehead) against a cheek for oil; a
  // freckled cheek varies the melanin fraction somewhere along a short row of points. The oil
  // map drives the sebum's index and the surface roughness (blood, oil twice, freckle mask: 4).
  check_scene("scenes/head_skin/head_skin_procedural.gltf", 4,
              {{"layers[2].components[0].fraction", {0.5, 0.47}, {0.5, 0.03}},
               {"layers[0].ior", {0.5, 0.15}, {0.3, 0.45}},
               {"roughness", {0.5, 0.15}, {0.3, 0.45}}});
}

TEST(DemoScenes, LeavesBindTheirPigmentMap) {
  // On the midrib (v = 0.5) against the blade between veins.
  check_scene("scenes/leaves/leaves_front.gltf", 1, {{"layers[1].components[0].fraction", {0.5, 0.5}, {0.2, 0.8}}});
  check_scene("scenes/leaves/leaves_back.gltf", 1, {{"layers[1].components[0].fraction", {0.5, 0.5}, {0.2, 0.8}}});
}

TEST(DemoScenes, MaterialMapEntriesMayCarryBindings) {
  // A --materials map entry given as an object overrides the glTF extras, with its own maps
  // (resolved against the map's directory).
  const fs::path dir = temp_dir("map");
  const std::string ramp = write_ramp_png(dir);
  const std::string map = (dir / "materials.json").string();
  std::ofstream(map) << json{{"leaf", {{"stack", source("scenes/materials/leaf.json")},
                                       {"bind", json::array({{{"parameter", "layers[0].thickness"},
                                                              {"texture", "ramp.png"},
                                                              {"range", {0.0, 0.05}}}})}}}}
                            .dump();
  const SceneDesc desc = load_gltf(source("scenes/leaves/leaves_front.gltf"));
  const LayeredBindings bound = bind_layered_materials(desc, map);
  const LayeredMaterial* m = bound.get(0);
  ASSERT_NE(m, nullptr);
  ASSERT_NE(m->bindings(), nullptr);
  ASSERT_EQ(m->bindings()->map_files().size(), 1u);
  EXPECT_EQ(fs::path(m->bindings()->map_files()[0]), fs::path(ramp).lexically_normal());
  ASSERT_EQ(m->bindings()->parameters().size(), 1u);
  EXPECT_EQ(m->bindings()->parameters()[0].path, "layers[0].thickness");
  // An unknown key in an object entry is an error naming the map.
  std::ofstream(map) << R"({"leaf": {"stack": "x.json", "bnd": []}})";
  try {
    bind_layered_materials(desc, map);
    ADD_FAILURE() << "accepted an unknown key";
  } catch (const SceneError& e) {
    EXPECT_NE(std::string(e.what()).find("leaf.bnd: unknown key"), std::string::npos) << e.what();
  }
}

TEST(DemoScenes, MisspeltExtrasKeysAreRejected) {
  // One triangle whose material's extras misspell "freckles".
  const fs::path dir = temp_dir("extras");
  const std::string gltf = (dir / "t.gltf").string();
  std::ofstream(gltf) << R"({"asset": {"version": "2.0"},
    "buffers": [{"uri": "data:application/octet-stream;base64,AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAA",
                 "byteLength": 36}],
    "bufferViews": [{"buffer": 0, "byteLength": 36}],
    "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
                   "min": [0, 0, 0], "max": [1, 1, 0]}],
    "materials": [{"name": "skin", "extras": {"lamina": {"stack": ")" +
                             source("scenes/materials/skin.json") + R"(", "frekles": {"density": 10}}}}],
    "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "material": 0}]}],
    "nodes": [{"mesh": 0}], "scenes": [{"nodes": [0]}], "scene": 0})";
  const SceneDesc desc = load_gltf(gltf);
  try {
    bind_layered_materials(desc, "");
    ADD_FAILURE() << "accepted extras.lamina.frekles; extras_json: " << desc.materials[0].extras_json;
  } catch (const SceneError& e) {
    EXPECT_NE(std::string(e.what()).find("material 'skin': extras.lamina.frekles: unknown key"), std::string::npos)
        << e.what();
  }
}

}  // namespace
}  // namespace lamina
