// Cost of `lamina fit`'s library (materials/fit/stack_fit): a single-slab inversion from R and T at
// normal incidence (iad's problem: the absorption and scattering coefficients of a slab of known
// thickness, index and g), for one channel and for all three, and one forward evaluation.
//   BM_FitSlab/<channels>/<quadrature points>/<coarse points>: fit_stack from a start away from the truth (sigma_a 1.5, sigma_s 20)
//     to noise-free data of the slab (sigma_a 0.3/1/2, sigma_s 8/12/15 per mm, g 0.8, 1 mm, n 1.4,
//     in air); coarse points 0: the optimiser on the accurate model alone (the fit before the
//     defect correction), 4: the default (FitSettings::coarse_quadrature_points); counters:
//     forward-model solutions per fit (optimiser and Jacobian), of which on the coarse model.
//   BM_FitForward: one forward evaluation (adding_doubling_totals, three channels, 16 points).
//   BM_FitRoughForward/<top>/<cold>: the red channel's R and T of the same slab under a rough top
//     (alpha 0.3; top 0 smooth, 1 the single-scattering model, over a Lambert substrate of
//     albedo 0.5 as that model needs, 2 the energy-conserving one), with the interface's
//     projection cached (cold 0: what every evaluation of a fit after the first costs) or made
//     anew (cold 1: alpha moved by 1e-9 each time, which misses interface_fourier.h's cache).
//   BM_FitRough/<top>: the one-channel fit of BM_FitSlab under the smooth (0) or energy-
//     conserving (2) top; its first iteration makes the projections at 4, 8, 16 and 32 points.
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

std::string rough_slab(const char* coefficients, int top) {
  return std::string(R"({"lamina_material": 1, "roughness": )") + (top == 0 ? "0" : "0.3") +
         R"(, "interface_model": ")" + (top == 1 ? "single_scattering" : "energy_conserving") +
         R"(", "layers": [{"ior": 1.4, "thickness": 1.0, )" + coefficients + R"(, "g": 0.8}], "below": )" + (top == 1 ? R"({"lambert": 0.5})" : R"({"ior": 1.0})") + "}";
}

void BM_FitRoughForward(benchmark::State& state) {
  const int top = static_cast<int>(state.range(0));
  const bool cold = state.range(1) != 0;
  lamina::LayerStack truth =
      lamina::parse_stack_json(rough_slab(R"("sigma_a": [0.3, 1.0, 2.0], "sigma_s": [8.0, 12.0, 15.0])", top), "slab");
  std::vector<lamina::FitMeasurement> d = slab_data(1);
  const double alpha = truth.top_roughness;
  int i = 0;
  for (auto _ : state) {
    if (cold) truth.top_roughness = alpha * (1.0 + 1e-9 * ++i);
    benchmark::DoNotOptimize(lamina::fit_model_values(truth, d));
  }
}
BENCHMARK(BM_FitRoughForward)->Args({0, 0})->Args({1, 0})->Args({1, 1})->Args({2, 0})->Args({2, 1})->Unit(benchmark::kMillisecond);

void BM_FitRough(benchmark::State& state) {
  const int top = static_cast<int>(state.range(0));
  const lamina::LayerStack truth =
      lamina::parse_stack_json(rough_slab(R"("sigma_a": [0.3, 1.0, 2.0], "sigma_s": [8.0, 12.0, 15.0])", top), "slab");
  const lamina::StackTemplate start = lamina::parse_stack_template_json(rough_slab(R"("sigma_a": 1.5, "sigma_s": 20.0)", top), "start");
  std::vector<lamina::FitMeasurement> d = slab_data(1);
  const std::vector<double> v = lamina::fit_model_values(truth, d);
  for (std::size_t k = 0; k < d.size(); ++k) d[k].value = v[k];
  const std::vector<lamina::FitParameterSpec> specs = {{"layers[0].sigma_a", 0.0, 10.0}, {"layers[0].sigma_s", 0.0, 100.0}};
  lamina::FitResult r;
  for (auto _ : state) benchmark::DoNotOptimize(r = lamina::fit_stack(start, specs, d));
  state.counters["evaluations"] = r.evaluations;
  state.counters["coarse"] = r.coarse_evaluations;
  state.counters["sigma_a_r"] = r.value[0];
}
BENCHMARK(BM_FitRough)->Arg(0)->Arg(2)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
