// The wavelength grid of the spectral mode's tables and albedos (renderer/layered/spectral_tables.h):
// how far the colour the film integrates moves when a stack's per-wavelength quantities are
// interpolated linearly from a grid of N nodes over 360-830 nm instead of computed at each
// wavelength. The quantities: the diffuse bihemispherical albedo (the lambert mode's, by
// adding-doubling) and the total reflectance R_specular + R_diffuse at normal and 60-degree
// incidence (the table's bins' sum). Reference: every 1 nm. For each stack and N, the largest
// error at one wavelength and the error of the colour (linear Rec. 709, D65, the film's
// quadrature: tests/materials/spectral/colour_quadrature.h), largest over the quantities and
// channels, and the time per grid stack of a full table (build_layered_table).
//
//   build/bench/spectral_table_grid [material.json ...]
#include <chrono>
#include <cmath>
#include <cstdio>
#include <optional>
#include <string>
#include <vector>

#include "materials/adding_doubling/adding_doubling.h"
#include "materials/stack/stack_file.h"
#include "materials/tables/albedo.h"
#include "materials/tables/layered_table.h"
#include "renderer/layered/spectral_tables.h"
#include "renderer/layered/wavelength_stack.h"
#include "tests/materials/spectral/colour_quadrature.h"

using namespace lamina;

namespace {

constexpr int kQuantities = 3;

// The quantities at three wavelengths at once (one stack, three channels).
void quantities(const LayerStack& stack, Spectrum out[kQuantities]) {
  out[0] = diffuse_bihemispherical_albedo_adding_doubling(stack);
  const double mus[2] = {1.0, 0.5};
  for (int q = 0; q < 2; ++q) {
    const AddingDoublingTotals t = adding_doubling_totals(stack, mus[q]);
    out[q + 1] = t.R_specular + t.R_diffuse;
  }
}

// A material as the renderer holds it: its RGB stack and, for a file with chromophore layers,
// those layers (as renderer/layered/wavelength_stack.h reads them).
struct Material {
  LayerStack stack;
  std::optional<SpectralStack> chromophores;
  const SpectralStack* spectral() const { return chromophores ? &*chromophores : nullptr; }
};

Material load(const std::string& file) {
  Material m{load_stack_file(file), std::nullopt};
  try {
    SpectralStack s = load_spectral_stack(file);
    for (const auto& c : s.chromophores)
      if (c) m.chromophores = std::move(s);
  } catch (const std::exception&) {  // coloured RGB layers: not a chromophore file
  }
  return m;
}

// quantity[q][i] at nm[i].
std::vector<std::vector<double>> at_wavelengths(const Material& s, const std::vector<double>& nm) {
  std::vector<std::vector<double>> v(kQuantities, std::vector<double>(nm.size()));
  for (std::size_t i = 0; i < nm.size(); i += 3) {
    const auto at = [&](std::size_t k) { return nm[std::min(i + k, nm.size() - 1)]; };
    LayerStack stack;
    stack_at_wavelengths(s.stack, s.spectral(), false, SampledWavelengths::at(at(0), at(1), at(2)), &stack);
    Spectrum q[kQuantities];
    quantities(stack, q);
    for (int k = 0; k < 3 && i + k < nm.size(); ++k)
      for (int j = 0; j < kQuantities; ++j) v[j][i + k] = q[j][k];
  }
  return v;
}

// Linear interpolation of samples at equally spaced nm (first, step).
double interpolate(const std::vector<double>& v, double first, double step, double nm) {
  const double x = (nm - first) / step;
  const std::size_t j = std::min(static_cast<std::size_t>(std::max(x, 0.0)), v.size() - 2);
  const double t = x - static_cast<double>(j);
  return (1.0 - t) * v[j] + t * v[j + 1];
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<std::string> files;
  for (int i = 1; i < argc; ++i) files.push_back(argv[i]);
  if (files.empty()) {
    const std::string root = LAMINA_SOURCE_DIR;
    files = {root + "/scenes/spectral/skin_spectral.json", root + "/scenes/spectral/skin_tone_1.json",
             root + "/scenes/spectral/skin_tone_7.json", root + "/scenes/materials/skin_oily.json"};
  }
  std::vector<double> fine;
  for (double nm = kSpectralFirstNm; nm <= kSpectralLastNm + 1e-9; nm += 1.0) fine.push_back(nm);
  std::printf("stack, nodes, spacing_nm, max_error_at_a_wavelength, max_colour_error, seconds_per_grid_table\n");
  for (const std::string& file : files) {
    const Material s = load(file);
    const auto reference = at_wavelengths(s, fine);
    for (int nodes : {12, 24, 48, 96}) {
      const WavelengthTableGrid grid{nodes};
      std::vector<double> nm;
      for (int j = 0; j < nodes; ++j) nm.push_back(grid.nm(j));
      const auto coarse = at_wavelengths(s, nm);
      const double step = grid.nm(1) - grid.nm(0);
      double worst = 0.0, worst_colour = 0.0;
      for (int q = 0; q < kQuantities; ++q) {
        for (std::size_t i = 0; i < fine.size(); ++i)
          worst = std::max(worst, std::abs(interpolate(coarse[q], kSpectralFirstNm, step, fine[i]) - reference[q][i]));
        const Spectrum exact = test::colour_by_quadrature([&](double x) { return interpolate(reference[q], kSpectralFirstNm, 1.0, x); });
        const Spectrum approx = test::colour_by_quadrature([&](double x) { return interpolate(coarse[q], kSpectralFirstNm, step, x); });
        for (int c = 0; c < kChannels; ++c) worst_colour = std::max(worst_colour, std::abs(approx[c] - exact[c]));
      }
      // A full table of one grid stack (three grid wavelengths), as the renderer builds it.
      const auto t0 = std::chrono::steady_clock::now();
      build_layered_table(stack_at_grid(s.stack, s.spectral(), false, grid, nodes / 6), TableSettings{});
      const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      std::printf("%s, %d, %.2f, %.5f, %.5f, %.3f\n", file.substr(file.rfind('/') + 1).c_str(), nodes, step, worst, worst_colour,
                  seconds);
      std::fflush(stdout);
    }
  }
  return 0;
}
