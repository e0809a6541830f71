// The targets of adding-doubling with a rough top (docs/adding_doubling.md, "Rough interfaces"):
// the table set of the three-layer rough skin (scenes/materials/skin_oily.json: the table mode's
// default TableSettings, 9 incidences x 12 x 24 bins per side) in at most 1 s, and its totals at
// one incidence in at most 5 ms. Prints wall-clock and process CPU seconds (the machine may be
// shared: CPU time is what the work costs), each the median of `repeats` runs:
//   table (cold): a roughness never projected before (the projection cache misses), as a
//                 scene's first table;
//   table (warm): the same stack again (the nodes' projection cached, as for a parameter table);
//   totals (cold): adding_doubling_totals at one incidence, the first at this roughness (the
//                 totals project mode 0 alone: another cache entry than the table's);
//   totals (warm): then at another incidence (only the incidence's columns are projected);
// for the single-scattering rough top, the energy-conserving one (interface_model
// energy_conserving: the microsurface's higher orders by walks, adding_doubling.cpp 11.), and the
// smooth stack (roughness 0) for comparison.
// Usage: bench_rough_tables [repeats] (default: $BENCH_REPEATS, else 5)
//        bench_rough_tables totals N: the energy-conserving top's totals alone, N calls at
//        incidences from 10 to 70 degrees after one cold call (the projection), for timing the
//        process as a whole (a whole-process timer, new build against old); prints the CPU ms per
//        call and a checksum of the totals.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <string>
#include <vector>

#include "materials/adding_doubling/adding_doubling.h"
#include "materials/stack/stack_file.h"
#include "materials/tables/layered_table.h"

namespace {

struct Time {
  double wall = 0.0, cpu = 0.0;
};

template <class F>
Time measure(F f) {
  const auto w0 = std::chrono::steady_clock::now();
  const std::clock_t c0 = std::clock();
  f();
  return {std::chrono::duration<double>(std::chrono::steady_clock::now() - w0).count(),
          static_cast<double>(std::clock() - c0) / CLOCKS_PER_SEC};
}

Time median(std::vector<Time> t) {
  auto mid = [&](auto key) {
    std::vector<double> v;
    for (const Time& x : t) v.push_back(key(x));
    std::sort(v.begin(), v.end());
    return v[v.size() / 2];
  };
  return {mid([](const Time& x) { return x.wall; }), mid([](const Time& x) { return x.cpu; })};
}

void report(const char* what, const Time& t) { std::printf("%-34s wall %8.4f s  cpu %8.4f s\n", what, t.wall, t.cpu); }

}  // namespace

// The totals mode: N warm calls of adding_doubling_totals with the energy-conserving top.
int totals_only(const lamina::LayerStack& base, int n) {
  lamina::LayerStack s = base;
  s.interface_model = lamina::InterfaceModel::EnergyConserving;
  lamina::adding_doubling_totals(s, 1.0);  // the cold projection of the nodes
  double checksum = 0.0;
  const Time t = measure([&] {
    for (int k = 0; k < n; ++k) {
      const double theta = 10.0 + 60.0 * k / std::max(1, n - 1);
      const lamina::AddingDoublingTotals r = lamina::adding_doubling_totals(s, std::cos(theta * 3.14159265358979323846 / 180.0));
      for (int c = 0; c < 3; ++c) checksum += r.R_specular[c] + r.R_diffuse[c] + r.R_hemispherical[c] + r.R_hemispherical_glossy[c];
    }
  });
  std::printf("energy-conserving totals (skin_oily): %d calls, cpu %.4f ms a call, wall %.4f ms a call, checksum %.17g\n", n,
              1e3 * t.cpu / n, 1e3 * t.wall / n, checksum);
  return 0;
}

int main(int argc, char** argv) {
  const lamina::LayerStack base = lamina::load_stack_file(std::string(LAMINA_SOURCE_DIR) + "/scenes/materials/skin_oily.json");
  if (argc > 2 && std::string(argv[1]) == "totals") return totals_only(base, std::max(1, std::atoi(argv[2])));
  const char* env = std::getenv("BENCH_REPEATS");
  const int repeats = std::max(1, argc > 1 ? std::atoi(argv[1]) : env ? std::atoi(env) : 5);
  const lamina::TableSettings settings;
  for (int variant : {0, 2, 1}) {
    const bool rough = variant != 1, energy_conserving = variant == 2;
    std::vector<Time> cold, warm, totals_cold, totals;
    for (int r = 0; r < repeats; ++r) {
      lamina::LayerStack s = base;
      // A new roughness per repeat (a cold projection), within 1e-6 of the preset's.
      s.top_roughness = rough ? base.top_roughness * (1.0 + 1e-7 * (r + 1)) : 0.0;
      s.interface_model = energy_conserving ? lamina::InterfaceModel::EnergyConserving : lamina::InterfaceModel::SingleScattering;
      cold.push_back(measure([&] { lamina::build_layered_table(s, settings); }));
      warm.push_back(measure([&] { lamina::build_layered_table(s, settings); }));
      const double mu = std::cos((20.0 + r) * 3.14159265358979323846 / 180.0);
      totals_cold.push_back(measure([&] { lamina::adding_doubling_totals(s, mu); }));
      const double mu2 = std::cos((50.0 + r) * 3.14159265358979323846 / 180.0);
      totals.push_back(measure([&] { lamina::adding_doubling_totals(s, mu2); }));
    }
    std::printf("%s (skin_oily, %d repeats, medians):\n",
                energy_conserving ? "energy-conserving rough top, roughness 0.4"
                : rough           ? "rough top, roughness 0.4"
                                  : "smooth top",
                repeats);
    report("  table set (cold)", median(cold));
    report("  table set (warm)", median(warm));
    report("  totals at one incidence (cold)", median(totals_cold));
    report("  totals at one incidence (warm)", median(totals));
  }
  return 0;
}
