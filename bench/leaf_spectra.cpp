// The cone-averaged total reflectance and transmittance of several leaf material files, every
// wavelength of a grid (materials/fit/spectral_fit.h, leaf_spectra): the layered leaf's model
// for fits, batched so that an energy-conserving rough cuticle is projected once per wavelength for all the
// files of a call (docs/spectral.md, "A rough cuticle").
//
// Usage: leaf_spectra --wavelengths FIRST:LAST:STEP --theta DEG[,DEG...] --weights W[,W...]
//                     [--quadrature-points N] FILE.json...
// Prints "nm" and the wavelengths, then per file a line "R" and a line "T" with its values
// (17 significant digits). Errors: one line on stderr, exit status 1.
#include <cmath>
#include <cstdio>
#include <exception>
#include <sstream>
#include <string>
#include <vector>

#include "materials/fit/spectral_fit.h"
#include "materials/spectral/wavelength_grid.h"
#include "materials/stack/stack_file.h"

namespace {

std::vector<double> numbers(const std::string& text, char separator, const std::string& option) {
  std::vector<double> out;
  std::stringstream ss(text);
  for (std::string item; std::getline(ss, item, separator);) {
    std::size_t used = 0;
    const double x = std::stod(item, &used);
    if (used != item.size() || !std::isfinite(x)) throw std::invalid_argument(option + ": not a number: " + item);
    out.push_back(x);
  }
  return out;
}

void print(const char* label, const std::vector<double>& values) {
  std::printf("%s", label);
  for (double v : values) std::printf(" %.17g", v);
  std::printf("\n");
}

}  // namespace

int main(int argc, char** argv) {
  try {
    std::vector<double> grid, theta, weights;
    std::vector<std::string> files;
    lamina::AddingDoublingSettings settings;
    settings.quadrature_points = 8;
    for (int i = 1; i < argc; ++i) {
      const std::string arg = argv[i];
      auto value = [&]() -> std::string {
        if (i + 1 >= argc) throw std::invalid_argument(arg + ": needs a value");
        return argv[++i];
      };
      if (arg == "--wavelengths") grid = numbers(value(), ':', arg);
      else if (arg == "--theta") theta = numbers(value(), ',', arg);
      else if (arg == "--weights") weights = numbers(value(), ',', arg);
      else if (arg == "--quadrature-points") settings.quadrature_points = static_cast<int>(numbers(value(), ',', arg).at(0));
      else if (arg.rfind("--", 0) == 0) throw std::invalid_argument(arg + ": unknown option");
      else files.push_back(arg);
    }
    if (grid.size() != 3) throw std::invalid_argument("--wavelengths: expected FIRST:LAST:STEP");
    if (files.empty()) throw std::invalid_argument("no material file given");
    const lamina::WavelengthGrid g = lamina::WavelengthGrid::from_to(grid[0], grid[1], grid[2]);
    std::vector<double> nm, cosines;
    for (int i = 0; i < g.count; ++i) nm.push_back(g.at(i));
    for (double deg : theta) {
      if (!(deg >= 0.0 && deg < 90.0)) throw std::invalid_argument("--theta: each angle in [0, 90) degrees");
      cosines.push_back(std::cos(deg * 3.14159265358979323846 / 180.0));
    }
    std::vector<lamina::SpectralStack> stacks;
    for (const std::string& f : files) stacks.push_back(lamina::load_spectral_stack(f));
    const lamina::LeafSpectra out = lamina::leaf_spectra(stacks, nm, cosines, weights, settings);
    print("nm", nm);
    for (std::size_t k = 0; k < stacks.size(); ++k) {
      print("R", out.r[k]);
      print("T", out.t[k]);
    }
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "leaf_spectra: %s\n", e.what());
    return 1;
  }
}
