// A uniform grid of wavelengths in nanometres: first, first + step, ..., count samples.
#pragma once

#include <stdexcept>

namespace lamina {

struct WavelengthGrid {
  double first_nm = 400.0;
  double step_nm = 10.0;
  int count = 1;

  double at(int i) const { return first_nm + step_nm * i; }
  double last_nm() const { return at(count - 1); }

  // The grid first, first + step, ... up to last (inclusive, within a millionth of a step).
  static WavelengthGrid from_to(double first, double last, double step) {
    if (!(step > 0.0) || !(last >= first)) throw std::invalid_argument("wavelength grid: needs step > 0 and last >= first");
    return {first, step, static_cast<int>((last - first) / step + 1e-6) + 1};
  }
};

}  // namespace lamina
