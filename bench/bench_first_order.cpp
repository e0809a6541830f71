// Cost of the analytic solutions for the contract's leaf (two layers, one composite): one
// zeroth-order evaluation, one first-order BRDF and BTDF evaluation, one directional albedo.
#include <benchmark/benchmark.h>

#include <cmath>

#include "materials/analytic/first_order.h"
#include "materials/stack/stack_file.h"
#include "materials/analytic/zeroth_order.h"

namespace {

lamina::LayerStack leaf() {
  return lamina::load_stack_file(std::string(LAMINA_SOURCE_DIR) + "/scenes/materials/contract_leaf.json");
}

void BM_ZerothOrder(benchmark::State& state) {
  const lamina::LayerStack s = leaf();
  double mu = 0.3;
  for (auto _ : state) {
    benchmark::DoNotOptimize(lamina::zeroth_order(s, mu));
    mu = mu > 0.9 ? 0.3 : mu + 1e-3;
  }
}
BENCHMARK(BM_ZerothOrder);

void BM_FirstOrderBrdf(benchmark::State& state) {
  const lamina::LayerStack s = leaf();
  const glm::dvec3 wi{0.5, 0.0, std::sqrt(0.75)};
  glm::dvec3 wo{-0.3, 0.4, std::sqrt(0.75)};
  for (auto _ : state) benchmark::DoNotOptimize(lamina::first_order_brdf(s, wi, wo));
}
BENCHMARK(BM_FirstOrderBrdf);

void BM_FirstOrderBtdf(benchmark::State& state) {
  const lamina::LayerStack s = leaf();
  const glm::dvec3 wi{0.5, 0.0, std::sqrt(0.75)};
  glm::dvec3 wo{-0.3, 0.4, -std::sqrt(0.75)};
  for (auto _ : state) benchmark::DoNotOptimize(lamina::first_order_btdf(s, wi, wo));
}
BENCHMARK(BM_FirstOrderBtdf);

void BM_FirstOrderAlbedo(benchmark::State& state) {
  const lamina::LayerStack s = leaf();
  for (auto _ : state) benchmark::DoNotOptimize(lamina::first_order_albedo(s, 0.7));
}
BENCHMARK(BM_FirstOrderAlbedo)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
