// Cost of `--subsurface auto`'s prediction (renderer/layered/subsurface_auto.h) for smooth
// stacks, where its reference is adding-doubling (no walks): docs/performance.md, "auto".
//   BM_AutoPrediction/<stack>: choose_subsurface_mode at the default settings (tolerance 0.05);
//     the stacks' rough tops (skin_oily) are made smooth, as the table mode sees them. Counters:
//     the quadrature points adding-doubling needed (the table mode's rule), the points of the
//     stage that decided (subsurface_auto.h: the reference in stages) and the walks (0).
#include <benchmark/benchmark.h>

#include <string>

#include "materials/tables/layered_table.h"
#include "materials/stack/stack_file.h"
#include "renderer/layered/layered_material.h"
#include "renderer/layered/subsurface_auto.h"

namespace {

void BM_AutoPrediction(benchmark::State& state, const std::string& file) {
  const lamina::LayerStack stack =
      lamina::with_smooth_top(lamina::load_stack_file(std::string(LAMINA_SOURCE_DIR) + "/scenes/materials/" + file));
  const lamina::LayeredMaterial material(stack, file);
  lamina::AutoSettings s;
  s.tolerance = 0.05;
  lamina::AutoChoice c;
  for (auto _ : state) c = lamina::choose_subsurface_mode(material, s);
  lamina::AddingDoublingSettings ad;
  lamina::adding_doubling_resolves(stack, s.table.quadrature_points, &ad);
  state.counters["points"] = ad.quadrature_points;
  state.counters["decided_at"] = c.reference_points;
  state.counters["walks"] = static_cast<double>(c.walks);
  state.SetLabel(c.reason.substr(0, c.reason.find(' ', 6)));
}

const bool registered = [] {
  for (const char* f : {"skin.json", "skin_oily.json", "leaf.json", "contract_leaf.json"})
    benchmark::RegisterBenchmark((std::string("BM_AutoPrediction/") + f).c_str(), BM_AutoPrediction, std::string(f))
        ->Unit(benchmark::kMillisecond);
  return true;
}();

}  // namespace

BENCHMARK_MAIN();
