// Cost of materials/adding_doubling/adding_doubling per stack and quadrature order, and the Monte Carlo walk's
// cost to reach the same error (docs/performance.md, "Adding-doubling"). Stacks: the skin presets (two
// composite layers over Lambert; skin_oily has three layers and two indices, its rough top made
// smooth, but its top layer, sebum, neither scatters nor absorbs), a three-layer skin (a
// hypodermis added to skin.json: three scattering layers, two indices), the contract leaf
// (two layers, transmitting), the MCML slab and a semi-infinite forward-peaked medium.
//   BM_AddingDoubling/<stack>/<order>: one call of adding_doubling_totals (all three channels,
//     collimated and diffuse incidence at once) at 45 degrees.
//   BM_WalkToEqualError/<stack>: one Monte Carlo run of 20000 walks; counters: its standard
//     error of R_diffuse (green), the adding-doubling error estimate at 16 points, and the
//     seconds the walk would need for a standard error equal to that estimate
//     (t * (stderr / error)^2, the 1/N law of the variance).
//   BM_Table/<stack>/<method>: the table mode's table (materials/tables/layered_table: 9 incidence
//     nodes, 12 x 24 bins per side) by adding-doubling or by the walk (50000 walks per node).
#include <benchmark/benchmark.h>

#include <chrono>
#include <cmath>
#include <string>
#include <vector>

#include "materials/adding_doubling/adding_doubling.h"
#include "materials/brdf/brdf_table.h"
#include "materials/tables/layered_table.h"
#include "materials/stack/stack_file.h"

namespace {

struct NamedStack {
  const char* name;
  lamina::LayerStack stack;
};

std::vector<NamedStack> stacks() {
  auto file = [](const char* f) { return lamina::load_stack_file(std::string(LAMINA_SOURCE_DIR) + "/scenes/materials/" + f); };
  lamina::LayerStack mcml;
  mcml.layers.push_back(lamina::make_layer("slab", 1.0, 0.2, lamina::Spectrum(1.0), lamina::Spectrum(9.0), lamina::Spectrum(0.75)));
  lamina::LayerStack semi;
  semi.layers.push_back(lamina::make_layer("half-space", 1.33, lamina::kInfiniteThickness, lamina::Spectrum(0.5, 1.0, 2.0),
                                           lamina::Spectrum(30.0), lamina::Spectrum(0.9)));
  // A three-layer skin (epidermis, dermis, hypodermis over the Lambert substrate): skin.json with
  // a 3 mm fat layer of index 1.44 added (illustrative adipose values after Jacques 2013, "Optical
  // properties of biological tissues: a review", Phys. Med. Biol. 58 R37: mu_s' ~1.3 /mm, g 0.9,
  // weak absorption), so three scattering layers and two indices.
  lamina::LayerStack three = file("skin.json");
  three.layers.push_back(lamina::make_layer("hypodermis", 1.44, 3.0, lamina::Spectrum(0.02, 0.03, 0.05),
                                            lamina::Spectrum(14.0, 13.0, 12.0), lamina::Spectrum(0.9)));
  return {{"skin", file("skin.json")},
          {"skin_3layer", three},
          {"skin_oily", lamina::with_smooth_top(file("skin_oily.json"))},  // as the table mode sees it
          {"leaf", file("contract_leaf.json")},
          {"mcml_slab", mcml},
          {"semi_infinite_g0.9", semi}};
}

const double kMu = std::cos(45.0 * 3.14159265358979323846 / 180.0);

void BM_AddingDoubling(benchmark::State& state, lamina::LayerStack stack, int order) {
  lamina::AddingDoublingSettings s;
  s.quadrature_points = order;
  lamina::AddingDoublingTotals t;
  for (auto _ : state) benchmark::DoNotOptimize(t = lamina::adding_doubling_totals(stack, kMu, s));
  state.counters["nodes"] = t.nodes;
  state.counters["doublings"] = t.doublings;
}

void BM_WalkToEqualError(benchmark::State& state, lamina::LayerStack stack) {
  lamina::BrdfOptions o;
  o.theta_i_deg = 45.0;
  o.samples = 20000;
  o.bins_theta = 1;
  o.bins_phi = 1;
  const lamina::AddingDoublingEstimate ad = lamina::adding_doubling_with_error(stack, kMu);
  double seconds = 0.0, se = 0.0;
  for (auto _ : state) {
    const auto t0 = std::chrono::steady_clock::now();
    const lamina::BrdfTable t = lamina::brdf_table_monte_carlo(stack, o);
    seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    se = t.totals.R_diffuse.stderr_[1];
  }
  const double err = std::max(ad.error.R_diffuse[1], 1e-7);
  state.counters["walk_stderr"] = se;
  state.counters["ad_error"] = err;
  state.counters["walk_s_to_equal_error"] = seconds * (se / err) * (se / err);
}

void BM_Table(benchmark::State& state, lamina::LayerStack stack, lamina::TableSettings::Method method) {
  lamina::TableSettings ts;
  ts.method = method;
  int order = 0;
  for (auto _ : state) {
    const lamina::LayeredTable t = lamina::build_layered_table(stack, ts);
    order = t.quadrature_points;
    benchmark::DoNotOptimize(t.value.data());
  }
  state.counters["points"] = order;
}

const bool registered = [] {
  for (const NamedStack& s : stacks()) {
    if (std::string(s.name) != "mcml_slab") {
      benchmark::RegisterBenchmark((std::string("BM_Table/") + s.name + "/adding-doubling").c_str(), BM_Table, s.stack,
                                   lamina::TableSettings::Method::AddingDoubling)
          ->Unit(benchmark::kMillisecond);
      benchmark::RegisterBenchmark((std::string("BM_Table/") + s.name + "/walk").c_str(), BM_Table, s.stack,
                                   lamina::TableSettings::Method::MonteCarlo)
          ->Unit(benchmark::kMillisecond)
          ->Iterations(1);
    }
    for (int order : {8, 16, 32})
      benchmark::RegisterBenchmark((std::string("BM_AddingDoubling/") + s.name + "/" + std::to_string(order)).c_str(),
                                   BM_AddingDoubling, s.stack, order)
          ->Unit(benchmark::kMillisecond);
    benchmark::RegisterBenchmark((std::string("BM_WalkToEqualError/") + s.name).c_str(), BM_WalkToEqualError, s.stack)
        ->Unit(benchmark::kMillisecond)
        ->Iterations(1);
  }
  return true;
}();

}  // namespace

BENCHMARK_MAIN();
