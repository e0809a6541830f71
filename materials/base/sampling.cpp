#include "materials/base/sampling.h"

#include <cmath>

namespace lamina {

namespace {

// r for 256 strips (Marsaglia and Tsang's table; with it the 255th strip above the base ends at
// height 1 to 1e-14), the common area v = exp(-r) (r + 1), and the strips' corners from
// exp(-x_(i+1)) = exp(-x_i) + v / x_i.
ExponentialZiggurat make_exponential_ziggurat() {
  ExponentialZiggurat z;
  const double r = 7.69711747013104972;
  const double v = std::exp(-r) * (r + 1.0);
  z.x[0] = r + 1.0;
  z.y[0] = 0.0;  // unused: the base strip's wedge is the tail
  z.x[1] = r;
  z.y[1] = std::exp(-r);
  for (int i = 1; i < 255; ++i) {
    z.y[i + 1] = z.y[i] + v / z.x[i];
    z.x[i + 1] = -std::log(z.y[i + 1]);
  }
  z.x[256] = 0.0;
  z.y[256] = 1.0;
  return z;
}

}  // namespace

const ExponentialZiggurat kExponentialZiggurat = make_exponential_ziggurat();

double exponential_ziggurat_edge(Rng& rng, int strip, double x) {
  const ExponentialZiggurat& z = kExponentialZiggurat;
  if (strip == 0) return z.x[1] - std::log(rng.uniform_open0());  // the tail beyond r
  const double height = z.y[strip] + rng.uniform() * (z.y[strip + 1] - z.y[strip]);
  return height < std::exp(-x) ? x : -1.0;
}

glm::dvec3 sample_cosine_hemisphere(glm::dvec2 u) {
  const double r = std::sqrt(u.x);
  const glm::dvec2 azimuth = unit_circle(u.y);
  const double z = std::sqrt(std::max(0.0, 1.0 - u.x));
  return {r * azimuth.x, r * azimuth.y, z};
}

}  // namespace lamina
