// Quadrature over the sphere of directions and histograms of sampled directions, for the
// chi-square tests of direction samplers (Mitsuba 3's approach: expected counts from the density
// integrated over each bin, independently of the sampler).
#pragma once

#include <algorithm>
#include <cmath>
#include <vector>

#include <glm/vec3.hpp>

#include "materials/analytic/first_order.h"  // gauss_legendre
#include "materials/base/sampling.h"

namespace lamina::test {

inline glm::dvec3 direction(double cos_theta, double phi) {
  const double s = std::sqrt(std::max(0.0, 1.0 - cos_theta * cos_theta));
  return {s * std::cos(phi), s * std::sin(phi), cos_theta};
}

// Integral over the bin [c0, c1] x [p0, p1] (cos theta, phi) of f(direction): n x n Gauss-Legendre.
template <class F>
double gauss_bin(double c0, double c1, double p0, double p1, const F& f, int n) {
  double xc[8], wc[8], xp[8], wp[8];
  gauss_legendre(n, c0, c1, xc, wc);
  gauss_legendre(n, p0, p1, xp, wp);
  double sum = 0.0;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) sum += wc[i] * wp[j] * f(direction(xc[i], xp[j]));
  return sum;
}

// The same, adaptive: a bin whose 4- and 8-point rules disagree by more than `tolerance` is split
// into quadrants (the rough dielectric's density is discontinuous where the refracted directions
// end, and GGX at small alpha is a narrow peak: a fixed rule misses both).
template <class F>
double integrate_bin(double c0, double c1, double p0, double p1, const F& f, double tolerance = 1e-7,
                     int depth = 0) {
  const double coarse = gauss_bin(c0, c1, p0, p1, f, 4);
  const double fine = gauss_bin(c0, c1, p0, p1, f, 8);
  if (std::abs(fine - coarse) <= tolerance || depth >= 10) return fine;
  const double cm = 0.5 * (c0 + c1), pm = 0.5 * (p0 + p1);
  const double t = 0.25 * tolerance;
  return integrate_bin(c0, cm, p0, pm, f, t, depth + 1) + integrate_bin(cm, c1, p0, pm, f, t, depth + 1) +
         integrate_bin(c0, cm, pm, p1, f, t, depth + 1) + integrate_bin(cm, c1, pm, p1, f, t, depth + 1);
}

// Integral of f over the sphere (or the upper hemisphere), by bins.
template <class F>
double integrate_sphere(const F& f, bool upper_only = false, int n_cos = 16, int n_phi = 8) {
  double sum = 0.0;
  const double c_lo = upper_only ? 0.0 : -1.0;
  for (int i = 0; i < n_cos; ++i)
    for (int j = 0; j < n_phi; ++j)
      sum += integrate_bin(c_lo + (1.0 - c_lo) * i / n_cos, c_lo + (1.0 - c_lo) * (i + 1) / n_cos,
                           2 * kPi * j / n_phi, 2 * kPi * (j + 1) / n_phi, f);
  return sum;
}

// Counts of sampled directions in (cos theta, phi) bins over the sphere, plus one last bin for
// samples that fail (none is expected for the visible normals).
struct Histogram {
  int n_cos, n_phi;
  std::vector<double> counts;
  Histogram(int c, int p) : n_cos(c), n_phi(p), counts(c * p + 1, 0.0) {}
  void add(const glm::dvec3& w) {
    const int i = std::min(n_cos - 1, static_cast<int>((w.z + 1.0) * 0.5 * n_cos));
    double phi = std::atan2(w.y, w.x);
    if (phi < 0.0) phi += 2 * kPi;
    const int j = std::min(n_phi - 1, static_cast<int>(phi / (2 * kPi) * n_phi));
    counts[i * n_phi + j] += 1.0;
  }
  void add_failure() { counts.back() += 1.0; }
  template <class F>
  std::vector<double> expected(const F& pdf, double n) const {
    std::vector<double> e(counts.size(), 0.0);
    double total = 0.0;
    for (int i = 0; i < n_cos; ++i)
      for (int j = 0; j < n_phi; ++j) {
        const double p = integrate_bin(-1.0 + 2.0 * i / n_cos, -1.0 + 2.0 * (i + 1) / n_cos, 2 * kPi * j / n_phi,
                                       2 * kPi * (j + 1) / n_phi, pdf);
        e[i * n_phi + j] = n * p;
        total += p;
      }
    e.back() = n * std::max(0.0, 1.0 - total);
    return e;
  }
};

}  // namespace lamina::test
