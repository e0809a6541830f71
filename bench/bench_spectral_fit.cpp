// Cost of `lamina fit --spectrum` (materials/fit/spectral_fit) on the NIST skin set, on one
// thread (docs/spectral.md, "Fitting a measured skin spectrum", quotes these numbers):
//   BM_SpectralModel/<points>: one modelled spectrum (adding-doubling at the 61 wavelengths
//     400-1000 nm of data/nist_skin/nist_skin_reflectance.csv) of scenes/spectral/skin_spectral.json
//     at that many quadrature points.
//   BM_SpectralFit/<subject>: the fit of one subject with scripts/nist_skin_fit.py's five
//     parameters at 8 quadrature points; counters: spectra solved (accurate and coarse), the RMSE
//     and the five fitted values.
#include <benchmark/benchmark.h>

#include <cmath>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <tbb/global_control.h>

#include "materials/fit/spectral_fit.h"
#include "materials/stack/stack_file.h"

namespace {

const double kCosTheta8 = std::cos(8.0 * 3.14159265358979323846 / 180.0);

lamina::SpectralStack skin() {
  return lamina::load_spectral_stack(std::string(LAMINA_SOURCE_DIR) + "/scenes/spectral/skin_spectral.json");
}

// The wavelengths and subject `s`'s column of the NIST CSV (its header: nm,subject_1,...).
void nist_subject(int s, std::vector<double>* nm, std::vector<double>* r) {
  std::ifstream in(std::string(LAMINA_SOURCE_DIR) + "/data/nist_skin/nist_skin_reflectance.csv");
  std::string line;
  bool header = true;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    if (header) {
      header = false;
      continue;
    }
    std::stringstream ss(line);
    std::string f;
    for (int k = 0; std::getline(ss, f, ','); ++k) {
      if (k == 0) nm->push_back(std::stod(f));
      if (k == s) r->push_back(std::stod(f));
    }
  }
}

const std::vector<lamina::FitParameterSpec> kParameters = {
    {"layers[0].chromophores.melanin", 0.0, 0.5},   {"layers[0].chromophores.eumelanin", 0.0, 1.0},
    {"layers[1].chromophores.blood", 0.0, 0.1},     {"layers[1].chromophores.oxygenation", 0.0, 1.0},
    {"layers[1].chromophores.scattering.reduced_500", 0.5, 10.0}};

void BM_SpectralModel(benchmark::State& state) {
  tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
  const lamina::SpectralStack stack = skin();
  std::vector<double> nm, r;
  nist_subject(1, &nm, &r);
  lamina::AddingDoublingSettings settings;
  settings.quadrature_points = static_cast<int>(state.range(0));
  for (auto _ : state) benchmark::DoNotOptimize(lamina::modelled_reflectance(stack, nm, kCosTheta8, settings));
}
BENCHMARK(BM_SpectralModel)->Arg(4)->Arg(6)->Arg(8)->Arg(16)->Unit(benchmark::kMillisecond);

void BM_SpectralFit(benchmark::State& state) {
  tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
  const lamina::SpectralStack stack = skin();
  std::vector<double> nm, r;
  nist_subject(static_cast<int>(state.range(0)), &nm, &r);
  lamina::AddingDoublingSettings settings;
  settings.quadrature_points = 8;
  lamina::SpectralFitResult fit;
  for (auto _ : state) benchmark::DoNotOptimize(fit = lamina::fit_spectrum(stack, kParameters, nm, r, kCosTheta8, settings));
  state.counters["spectra"] = fit.evaluations;
  state.counters["coarse"] = fit.coarse_evaluations;
  state.counters["rmse"] = fit.rmse;
  for (std::size_t k = 0; k < fit.values.size(); ++k) state.counters["p" + std::to_string(k)] = fit.values[k];
}
BENCHMARK(BM_SpectralFit)->Arg(1)->Arg(14)->Arg(44)->Arg(94)->Unit(benchmark::kMillisecond)->Iterations(1);

}  // namespace

BENCHMARK_MAIN();
