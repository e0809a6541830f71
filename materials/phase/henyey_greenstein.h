// The Henyey-Greenstein phase function (Henyey and Greenstein, ApJ 93, 1941):
//   p(cos) = (1 - g^2) / (4 pi (1 + g^2 - 2 g cos)^(3/2)),  normalised over the sphere, mean
// cosine g. cos is the cosine between the propagation directions before and after scattering.
#pragma once

#include <algorithm>
#include <cmath>

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include "materials/base/sampling.h"

namespace lamina {

// Defined inline: they are the walk's every-event step (sampling, rotation) and every
// connection's phase value, and a call each was a measurable part of an event.

// Valid for |g| < 1, accurate up to |g| = 0.9999: the base 1 + g^2 - 2 g cos is formed without
// cancellation on either side of g = 0.
inline double henyey_greenstein(double cos_theta, double g) {
  const double mu = std::clamp(cos_theta, -1.0, 1.0);
  // 1 + g^2 - 2 g mu written as a sum of non-negative terms:
  //   g >= 0: (1 - g)^2 + 2 g (1 - mu);   g < 0: (1 + g)^2 - 2 g (1 + mu).
  const double base = g >= 0.0 ? (1.0 - g) * (1.0 - g) + 2.0 * g * (1.0 - mu)
                                : (1.0 + g) * (1.0 + g) - 2.0 * g * (1.0 + mu);
  return kInv4Pi * (1.0 - g) * (1.0 + g) / (base * std::sqrt(base));
}

// Inverse-CDF sample of cos(theta) for a uniform u in [0, 1).
//
// The CDF is P(mu) = (1 - g^2)/(2g) [ (1 + g^2 - 2 g mu)^(-1/2) - (1 + g)^(-1) ]; solving
// P = u gives mu = (1 + g^2 - s^2)/(2g), s = (1 - g^2)/(1 + g xi), xi = 2u - 1. (The slides'
// 1/|2g| flips the sign of mu for g < 0.) That form cancels catastrophically as g -> 0, so we
// expand it: with t = 1 + g xi,
//   mu = [ xi + g (3 + xi^2 + 2 g xi + g^2 (xi^2 - 1)) / 2 ] / t^2,
// which is exact algebraically, equals xi (isotropic) at g = 0 and 1 at g = 1.
inline double sample_henyey_greenstein_cos(double g, double u) {
  const double xi = 2.0 * u - 1.0;
  const double t = 1.0 + g * xi;
  const double num = xi + 0.5 * g * (3.0 + xi * xi + 2.0 * g * xi + g * g * (xi * xi - 1.0));
  return std::clamp(num / (t * t), -1.0, 1.0);
}

// Rotates the unit vector d to the direction with cos(theta) = cos_theta from d and azimuth phi
// about it, (cos phi, sin phi) = azimuth (unit_circle), using a continuous orthonormal basis (no
// division by sin(theta), so d = +-z works).
inline glm::dvec3 rotate_direction(const glm::dvec3& d, double cos_theta, glm::dvec2 azimuth) {
  glm::dvec3 t, b;
  orthonormal_basis(d, &t, &b);
  const double sin_theta = std::sqrt(std::max(0.0, (1.0 - cos_theta) * (1.0 + cos_theta)));
  glm::dvec3 w = sin_theta * azimuth.x * t + sin_theta * azimuth.y * b + cos_theta * d;
  // |w|^2 = 1 + e with e of the order of rounding (d unit, the basis orthonormal): one Newton step
  // of 1/sqrt, 1 - e/2, leaves an error of order e^2 without the square root and the division,
  // which were most of this function's time on the walk's critical path. It also removes a
  // previous step's rounding, so the length cannot drift over a walk's events.
  const double length2 = w.x * w.x + w.y * w.y + w.z * w.z;
  return w * (1.5 - 0.5 * length2);
}

// A direction scattered from the propagation direction d (unit) by HG with parameter g.
inline glm::dvec3 sample_henyey_greenstein(const glm::dvec3& d, double g, double u1, double u2) {
  return rotate_direction(d, sample_henyey_greenstein_cos(g, u1), unit_circle(u2));
}

}  // namespace lamina
