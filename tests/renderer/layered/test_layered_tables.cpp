// The table mode's tables along texture-driven parameters (renderer/layered/layered_tables.h):
// parameters one map channel drives share an axis, the two most correlated maps span a plane of
// node tables, and the model is the hit's own adding-doubling table at every node; between
// nodes, on correlated maps, it errs less than the separable product of exact tables, and on
// the side that the convexity of ln T in absorber fractions predicts.
#include "renderer/layered/layered_tables.h"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "materials/stack/stack_file.h"
#include "materials/stack/stack_parameters.h"
#include "materials/tables/layered_table.h"
#include "renderer/layered/layered_material.h"
#include "renderer/layered/stack_bindings.h"
#include "renderer/scene/scene_gltf.h"
#include "renderer/surfaces/table_surface.h"
#include "tests/support/image_files.h"

namespace lamina {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

std::string source(const std::string& rel) { return std::string(LAMINA_SOURCE_DIR) + "/" + rel; }

fs::path temp_dir(const std::string& name) {
  const fs::path d = fs::temp_directory_path() / ("lamina_test_layered_tables_" + name);
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

// 16 x 16 RGB: r rises along x, g = 0.7 r + 0.3 y (correlated with r, 0.92), b along y.
void write_correlated_maps(const fs::path& dir) {
  std::vector<unsigned char> px;
  for (int y = 0; y < 16; ++y)
    for (int x = 0; x < 16; ++x) {
      const double r = x / 15.0, b = y / 15.0, g = 0.7 * r + 0.3 * b;
      for (double v : {r, g, b}) px.push_back(static_cast<unsigned char>(std::lround(255.0 * v)));
    }
  test::write_png8((dir / "maps.png").string(), 16, 16, 3, px);
}

struct Fixture {
  std::shared_ptr<const StackTemplate> tmpl;
  std::shared_ptr<const StackBindings> b;
  LayeredBindings bindings;
  const LayeredMaterial* m = nullptr;
  SceneDesc scene;
  Fixture(const std::string& name, const std::string& bind) {
    const fs::path dir = temp_dir(name);
    write_correlated_maps(dir);
    tmpl = std::make_shared<const StackTemplate>(load_stack_template(source("scenes/materials/skin.json")));
    scene.path = "scene.gltf";
    const std::string map = (dir / "map.json").string();
    b = std::make_shared<const StackBindings>(json::parse(bind), tmpl, scene, map, "skin", map);
    bindings.by_material.push_back(std::make_shared<const LayeredMaterial>(tmpl->stack, "skin.json", b));
    m = bindings.by_material[0].get();
  }
  // The stack with the parameters at `values`.
  LayerStack stack(const std::vector<Spectrum>& values) const {
    LayerStack s;
    apply_parameters(*tmpl, b->parameters(), values.data(), &s);
    return s;
  }
};

// The model's table for parameter values `v`, bin by bin, against the adding-doubling table of
// the stack at `v`: the largest relative difference (bins above 1e-6 of the node's power), and
// per incidence node the directional albedos (sum of f times the bins' projected solid angle).
struct ModelCheck {
  double max_relative = 0.0;
  std::vector<Spectrum> albedo_model, albedo_truth;
};

ModelCheck check_model(const LayeredTables& tables, const Fixture& f, const std::vector<Spectrum>& v,
                       const LayeredTable* truth_in = nullptr) {
  TableFactor factors[LayeredTables::kMaxFactors];
  const int n = tables.factors(f.m, false, v.data(), factors);
  const LayeredTable& base = tables.get(f.m, false);
  const LayerStack s = f.stack(v);
  const LayeredTable truth = truth_in ? *truth_in : build_layered_table(s, base.settings);
  ModelCheck c;
  const int K = base.settings.bins_theta, M = base.settings.bins_phi;
  for (int node = 0; node < base.settings.nodes; ++node) {
    Spectrum am(0.0), at(0.0);
    for (int bin = 0; bin < base.bins(); ++bin) {
      const Spectrum model = table_model_value(base, factors, n, node, bin);
      const Spectrum t = truth.at(node, bin);
      const double omega = truth.projected_solid_angle((bin / M) % K);
      am += model * omega;
      at += t * omega;
      for (int ch = 0; ch < kChannels; ++ch)
        if (t[ch] > 1e-6 * truth.power[node]) c.max_relative = std::max(c.max_relative, std::abs(model[ch] / t[ch] - 1.0));
    }
    c.albedo_model.push_back(am);
    c.albedo_truth.push_back(at);
  }
  return c;
}

// The separable product of exact tables, T(a, b0) T(a0, b) / T0: what the model was before the
// plane, without its interpolation error. Its largest relative albedo error against the truth.
double separable_albedo_error(const Fixture& f, const std::vector<Spectrum>& base_values, const std::vector<Spectrum>& v,
                              std::size_t a, std::size_t b, const TableSettings& ts) {
  std::vector<Spectrum> va = base_values, vb = base_values;
  va[a] = v[a];
  vb[b] = v[b];
  const LayeredTable t0 = build_layered_table(f.stack(base_values), ts), ta = build_layered_table(f.stack(va), ts),
                     tb = build_layered_table(f.stack(vb), ts), truth = build_layered_table(f.stack(v), ts);
  double worst = 0.0;
  const int K = ts.bins_theta, M = ts.bins_phi;
  for (int node = 0; node < ts.nodes; ++node) {
    Spectrum am(0.0), at(0.0);
    for (int bin = 0; bin < t0.bins(); ++bin) {
      const double omega = truth.projected_solid_angle((bin / M) % K);
      for (int ch = 0; ch < kChannels; ++ch) {
        const double base = t0.at(node, bin)[ch];
        am[ch] += (base > 0.0 ? ta.at(node, bin)[ch] * tb.at(node, bin)[ch] / base : 0.0) * omega;
      }
      at += truth.at(node, bin) * omega;
    }
    for (int ch = 0; ch < kChannels; ++ch) worst = std::max(worst, std::abs(am[ch] / at[ch] - 1.0));
  }
  return worst;
}

// Melanin (r) and blood (g) on correlated maps span the plane; the epidermis's index (b) gets a
// line. At every plane node and line node the model is the node stack's own table (to 1e-9).
// At cell centres on the correlated diagonal: never below the truth by more than
// adding-doubling's own discretisation (2e-4 of the table, docs/modes.md), closer than
// interpolating T itself (ln T is convex in the absorber fractions: layered_tables.h), and
// above the base point closer than the separable product of exact tables.
TEST(LayeredTables, PlaneOfCorrelatedMapsIsExactAtItsNodes) {
  const Fixture f("plane", R"({"bind": [
      {"parameter": "layers[0].components[0].fraction", "texture": "maps.png", "channel": "r", "range": [0.0, 0.08]},
      {"parameter": "layers[1].components[0].fraction", "texture": "maps.png", "channel": "g", "range": [0.005, 0.1]},
      {"parameter": "layers[0].ior", "texture": "maps.png", "channel": "b", "range": [1.35, 1.45]}]})");
  const TableSettings ts;
  const LayeredTables tables(f.bindings, ts);
  const StackBindings::Nodes n[3] = {f.b->nodes(0, 5), f.b->nodes(1, 5), f.b->nodes(2, 5)};
  for (const auto& nk : n) ASSERT_EQ(nk.values.size(), 5u);
  EXPECT_EQ(tables.parameter_tables(), 25 + 5);
  std::vector<Spectrum> base = {n[0].values[n[0].central], n[1].values[n[1].central], n[2].values[n[2].central]};
  {
    TableFactor factors[LayeredTables::kMaxFactors];
    ASSERT_EQ(tables.factors(f.m, false, base.data(), factors), 2);
    EXPECT_TRUE(factors[0].lo2 != nullptr) << "the plane";
    EXPECT_TRUE(factors[1].lo2 == nullptr) << "the line";
  }
  // Plane nodes (every i, three j each) and line nodes.
  for (std::size_t i = 0; i < 5; ++i)
    for (std::size_t j : {i, (i + 2) % 5, (i + 4) % 5}) {
      std::vector<Spectrum> v = base;
      v[0] = n[0].values[i];
      v[1] = n[1].values[j];
      EXPECT_LT(check_model(tables, f, v).max_relative, 1e-9) << "plane node " << i << ", " << j;
    }
  for (std::size_t k = 0; k < 5; ++k) {
    std::vector<Spectrum> v = base;
    v[2] = n[2].values[k];
    EXPECT_LT(check_model(tables, f, v).max_relative, 1e-9) << "line node " << k;
  }
  // Cell centres on the diagonal (both maps rise together), the index at its base value.
  auto albedo = [&](const LayeredTable& t, int node) {
    Spectrum a(0.0);
    for (int bin = 0; bin < t.bins(); ++bin)
      a += t.at(node, bin) * t.projected_solid_angle((bin / ts.bins_phi) % ts.bins_theta);
    return a;
  };
  for (std::size_t i : {0, 1, 3}) {
    std::vector<Spectrum> v = base;
    v[0] = 0.5 * (n[0].values[i] + n[0].values[i + 1]);
    v[1] = 0.5 * (n[1].values[i] + n[1].values[i + 1]);
    const ModelCheck c = check_model(tables, f, v);
    TableFactor fs[LayeredTables::kMaxFactors];
    ASSERT_EQ(tables.factors(f.m, false, v.data(), fs), 2);
    double worst = 0.0, lowest = 0.0, worst_linear = 0.0;
    for (std::size_t node = 0; node < c.albedo_model.size(); ++node) {
      const int j = static_cast<int>(node);
      // Interpolating T instead of ln T: the albedo is linear in the bins.
      const Spectrum linear = (albedo(*fs[0].lo, j) * (1.0 - fs[0].t) + albedo(*fs[0].hi, j) * fs[0].t) * (1.0 - fs[0].t2) +
                              (albedo(*fs[0].lo2, j) * (1.0 - fs[0].t) + albedo(*fs[0].hi2, j) * fs[0].t) * fs[0].t2;
      for (int ch = 0; ch < kChannels; ++ch) {
        const double e = c.albedo_model[node][ch] / c.albedo_truth[node][ch] - 1.0;
        worst = std::max(worst, std::abs(e));
        lowest = std::min(lowest, e);
        worst_linear = std::max(worst_linear, std::abs(linear[ch] / c.albedo_truth[node][ch] - 1.0));
      }
    }
    const double separable = separable_albedo_error(f, base, v, 0, 1, ts);
    std::printf("cell %zu centre: albedo error of the plane %.3g (lowest %.3g), interpolating T instead of ln T %.3g, "
                "the separable product of exact tables %.3g\n", i, worst, lowest, worst_linear, separable);
    EXPECT_GT(lowest, -2e-4) << "cell " << i << ": below the truth";
    EXPECT_LT(worst, worst_linear) << "cell " << i;
    // Above the base point, where melanin's curvature in ln T is small, the plane's interpolation
    // beats the product's missing cross term (near zero melanin, ln T ~ -sqrt(sigma_a) curves
    // most and the interpolation error dominates: docs/performance.md, the face benchmark).
    if (i > n[0].central) EXPECT_LT(worst, separable) << "cell " << i;
  }
}

// Two parameters on one map channel (melanin rising, the dermis's thickness falling with r) move
// together: one axis of 5 node tables, exact at each (the nodes matched by map value t).
TEST(LayeredTables, ParametersOfOneMapShareAnAxis) {
  const Fixture f("group", R"({"bind": [
      {"parameter": "layers[0].components[0].fraction", "texture": "maps.png", "channel": "r", "range": [0.0, 0.08]},
      {"parameter": "layers[1].thickness", "texture": "maps.png", "channel": "r", "range": [2.0, 1.0]}]})");
  const LayeredTables tables(f.bindings, TableSettings{});
  EXPECT_EQ(tables.parameter_tables(), 5);
  const StackBindings::Nodes melanin = f.b->nodes(0, 5), thickness = f.b->nodes(1, 5);
  ASSERT_EQ(melanin.values.size(), 5u);
  ASSERT_EQ(melanin.source, thickness.source);
  for (std::size_t i = 0; i < 5; ++i) {
    const double t = melanin.t[i];
    const std::vector<Spectrum> v = {Spectrum(0.08 * t), Spectrum(2.0 - t)};
    EXPECT_LT(check_model(tables, f, v).max_relative, 1e-9) << "node " << i;
  }
}

// The same bindings give the same tables and model, bit for bit (tables are built in a fixed
// order; the plane's choice depends on the maps only).
TEST(LayeredTables, Deterministic) {
  const std::string bind = R"({"bind": [
      {"parameter": "layers[0].components[0].fraction", "texture": "maps.png", "channel": "r", "range": [0.0, 0.08]},
      {"parameter": "layers[1].components[0].fraction", "texture": "maps.png", "channel": "g", "range": [0.005, 0.1]}]})";
  const Fixture f1("det1", bind), f2("det2", bind);
  TableSettings ts;
  ts.quadrature_points = 8;
  const LayeredTables t1(f1.bindings, ts), t2(f2.bindings, ts);
  ASSERT_EQ(t1.parameter_tables(), t2.parameter_tables());
  const std::vector<Spectrum> v = {Spectrum(0.013), Spectrum(0.031)};
  TableFactor a[LayeredTables::kMaxFactors], b[LayeredTables::kMaxFactors];
  const int na = t1.factors(f1.m, false, v.data(), a), nb = t2.factors(f2.m, false, v.data(), b);
  ASSERT_EQ(na, nb);
  for (int node = 0; node < ts.nodes; ++node)
    for (int bin = 0; bin < t1.get(f1.m, false).bins(); ++bin) {
      const Spectrum x = table_model_value(t1.get(f1.m, false), a, na, node, bin);
      const Spectrum y = table_model_value(t2.get(f2.m, false), b, nb, node, bin);
      for (int ch = 0; ch < kChannels; ++ch) ASSERT_EQ(x[ch], y[ch]) << "node " << node << " bin " << bin;
    }
}

}  // namespace
}  // namespace lamina
