// Random walk throughput: photons per second for `lamina brdf --method monte-carlo` on the MCML
// slab and a skin-like three-layer stack, with 1 and 2 threads; connection weights and analytic
// first-order evaluations per second.
#include <benchmark/benchmark.h>
#include <tbb/global_control.h>

#include "materials/brdf/brdf_table.h"
#include "materials/analytic/first_order.h"
#include "materials/walk/random_walk.h"

namespace {

using namespace lamina;

LayerStack mcml_slab() {
  LayerStack s;
  s.layers.push_back(make_layer("slab", 1.0, 0.2, Spectrum(1.0), Spectrum(9.0), Spectrum(0.75)));
  return s;
}

// Skin-like (values of the order of the tissue optics literature, per mm): a thin absorbing
// epidermis, a dermis, a semi-infinite subcutis; strongly forward scattering, many events.
LayerStack skin() {
  LayerStack s;
  s.layers.push_back(make_layer("epidermis", 1.4, 0.1, Spectrum(0.3, 0.6, 1.2), Spectrum(30.0), Spectrum(0.8)));
  s.layers.push_back(make_layer("dermis", 1.4, 1.0, Spectrum(0.05, 0.15, 0.3), Spectrum(20.0), Spectrum(0.8)));
  s.layers.push_back(make_layer("subcutis", 1.4, kInfiniteThickness, Spectrum(0.01, 0.02, 0.05), Spectrum(12.0),
                                Spectrum(0.9)));
  return s;
}

void run_table(benchmark::State& state, const LayerStack& stack) {
  tbb::global_control threads(tbb::global_control::max_allowed_parallelism, static_cast<std::size_t>(state.range(0)));
  BrdfOptions o;
  o.theta_i_deg = 30.0;
  o.samples = static_cast<std::uint64_t>(state.range(1));
  std::uint64_t seed = 1;
  for (auto _ : state) {
    o.seed = seed++;
    benchmark::DoNotOptimize(brdf_table_monte_carlo(stack, o));
  }
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations() * o.samples));
}

void BM_PhotonsMcmlSlab(benchmark::State& state) { run_table(state, mcml_slab()); }
void BM_PhotonsSkin(benchmark::State& state) { run_table(state, skin()); }
BENCHMARK(BM_PhotonsMcmlSlab)->Args({1, 200000})->Args({2, 200000})->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_PhotonsSkin)->Args({1, 5000})->Args({2, 5000})->Unit(benchmark::kMillisecond)->UseRealTime();

// Events per second of the bare walk (one thread), for the renderer's budget.
void BM_WalkEventsSkin(benchmark::State& state) {
  const LayerStack s = skin();
  const glm::dvec3 wi = incident_direction(30.0, 0.0);
  std::uint64_t i = 0, events = 0;
  for (auto _ : state) {
    Rng rng(3, i++);
    const WalkResult r = random_walk(s, wi, rng);
    events += static_cast<std::uint64_t>(r.interactions);
    benchmark::DoNotOptimize(r);
  }
  state.SetItemsProcessed(static_cast<std::int64_t>(events));
}
BENCHMARK(BM_WalkEventsSkin);

ScatterEvent sample_event(const LayerStack& s) {
  ScatterEvent e;
  e.layer = 1;
  e.depth = 0.3;
  e.direction = glm::normalize(glm::dvec3(0.2, 0.1, -0.9));
  e.throughput = Spectrum(0.5);
  (void)s;
  return e;
}

void BM_ConnectionWeight(benchmark::State& state) {
  const LayerStack s = skin();
  const ScatterEvent e = sample_event(s);
  const glm::dvec3 w = incident_direction(40.0, 120.0);
  for (auto _ : state) benchmark::DoNotOptimize(connection_weight(s, e, w));
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_ConnectionWeight);

void BM_ConnectionWeightAllPathsPrepared(benchmark::State& state) {
  const LayerStack s = skin();
  const ScatterEvent e = sample_event(s);
  const ConnectionTarget target = prepare_connection(s, incident_direction(40.0, 120.0));
  for (auto _ : state) benchmark::DoNotOptimize(connection_weight_all_paths(s, e, target));
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_ConnectionWeightAllPathsPrepared);

void BM_FirstOrderBrdf(benchmark::State& state) {
  const LayerStack s = skin();
  const glm::dvec3 wi = incident_direction(30.0, 0.0), wo = incident_direction(50.0, 140.0);
  for (auto _ : state) benchmark::DoNotOptimize(first_order_brdf(s, wi, wo));
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_FirstOrderBrdf);

}  // namespace

BENCHMARK_MAIN();
