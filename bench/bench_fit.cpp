// Cost of `lamina fit`'s library (materials/fit/stack_fit): a single-slab inversion from R and T at
// normal incidence (iad's problem: the absorption and scattering coefficients of a slab of known
// thickness, index and g), for one channel and for all three, and one forward evaluation.
//   BM_FitSlab/<channels>/<quadrature points>/<coarse points>: fit_stack from a start away from the truth (sigma_a 1.5, sigma_s 20)
//     to noise-free data of the slab (sigma_a 0.3/1/2, sigma_s 8/12/15 per mm, g 0.8, 1 mm, n 1.4,
//     in air); coarse points 0: the optimiser on the accurate model alone (the fit before the
//     defect correction), 4: the default (FitSettings::coarse_quadrature_points); counters:
//     forward-model solutions per fit (optimiser and Jacobian), of which on the coarse model.
//   BM_FitForward: one forward evaluation (adding_doubling_totals, three channels, 16 points).
// docs/performance.md, "Fitting", quotes these numbers.
#include <benchmark/benchmark.h>

#include <string>
#include <vector>

#include "materials/stack/stack_file.h"
#include "materials/fit/stack_fit.h"

namespace {

const char* kSlab = R"({"lamina_material": 1, "layers": [
  {"ior": 1.4, "thickness": 1.0, "sigma_a": [0.3, 1.0, 2.0], "sigma_s": [8.0, 12.0, 15.0], "g": 0.8}],
  "below": {"ior": 1.0}})";
const char* kStart = R"({"lamina_material": 1, "layers": [
  {"ior": 1.4, "thickness": 1.0, "sigma_a": 1.5, "sigma_s": 20.0, "g": 0.8}], "below": {"ior": 1.0}})";

std::vector<lamina::FitMeasurement> slab_data(int channels) {
  const lamina::LayerStack truth = lamina::parse_stack_json(kSlab, "slab");
  std::vector<lamina::FitMeasurement> d;
  for (int c = 0; c < channels; ++c)
    for (lamina::FitQuantity q : {lamina::FitQuantity::kR, lamina::FitQuantity::kT}) {
      lamina::FitMeasurement m;
      m.quantity = q;
      m.channel = c;
      m.sigma = 1e-3;
      d.push_back(m);
    }
  const std::vector<double> v = lamina::fit_model_values(truth, d);
  for (std::size_t i = 0; i < d.size(); ++i) d[i].value = v[i];
  return d;
}

void BM_FitSlab(benchmark::State& state) {
  const int channels = static_cast<int>(state.range(0));
  lamina::FitSettings settings;
  settings.forward.quadrature_points = static_cast<int>(state.range(1));
  settings.coarse_quadrature_points = static_cast<int>(state.range(2));
  const lamina::StackTemplate start = lamina::parse_stack_template_json(kStart, "start");
  const std::vector<lamina::FitMeasurement> d = slab_data(channels);
  const std::vector<lamina::FitParameterSpec> specs = {{"layers[0].sigma_a", 0.0, 10.0}, {"layers[0].sigma_s", 0.0, 100.0}};
  lamina::FitResult r;
  for (auto _ : state) benchmark::DoNotOptimize(r = lamina::fit_stack(start, specs, d, settings));
  state.counters["evaluations"] = r.evaluations;
  state.counters["coarse"] = r.coarse_evaluations;
  state.counters["chi2"] = r.chi2;
  state.counters["sigma_a_r"] = r.value[0];
}
BENCHMARK(BM_FitSlab)
    ->Args({1, 8, 0})
    ->Args({1, 16, 0})
    ->Args({1, 16, 4})
    ->Args({3, 8, 0})
    ->Args({3, 16, 0})
    ->Args({3, 16, 4})
    ->Unit(benchmark::kMillisecond);

void BM_FitForward(benchmark::State& state) {
  const lamina::LayerStack truth = lamina::parse_stack_json(kSlab, "slab");
  const std::vector<lamina::FitMeasurement> d = slab_data(3);
  for (auto _ : state) benchmark::DoNotOptimize(lamina::fit_model_values(truth, d));
}
BENCHMARK(BM_FitForward)->Unit(benchmark::kMicrosecond);

}  // namespace

BENCHMARK_MAIN();
