#include "materials/phase/dwivedi.h"

#include <algorithm>
#include <cmath>

#include "materials/base/sampling.h"

namespace lamina {

double dwivedi_v0(double alpha) {
  if (!(alpha >= 0.56) || !(alpha < 1.0)) return 0.0;
  const double exponent = 2.44294 - 0.0215813 * alpha + 0.578637 / alpha;
  const double x = 1.0 - std::pow(alpha, exponent);
  return x > 0.0 ? 1.0 / std::sqrt(x) : 0.0;
}

double dwivedi_pdf(double v0, double mu) {
  return 1.0 / (2.0 * kPi * std::log((v0 + 1.0) / (v0 - 1.0)) * (v0 - mu));
}

double sample_dwivedi_cos(double v0, double u) {
  const double mu = v0 - (v0 + 1.0) * std::pow((v0 - 1.0) / (v0 + 1.0), u);
  return std::clamp(mu, -1.0, 1.0);
}

}  // namespace lamina
