// The Henyey-Greenstein phase function (Henyey and Greenstein, ApJ 93, 1941):
//   p(cos) = (1 - g^2) / (4 pi (1 + g^2 - 2 g cos)^(3/2)),  normalised over the sphere, mean
// cosine g. cos is the cosine between the propagation directions before and after scattering.
#pragma once

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

namespace lamina {

// Valid for |g| < 1, accurate up to |g| = 0.9999: the base 1 + g^2 - 2 g cos is formed without
// cancellation on either side of g = 0.
double henyey_greenstein(double cos_theta, double g);

// Inverse-CDF sample of cos(theta) for a uniform u in [0, 1).
//
// The CDF is P(mu) = (1 - g^2)/(2g) [ (1 + g^2 - 2 g mu)^(-1/2) - (1 + g)^(-1) ]; solving
// P = u gives mu = (1 + g^2 - s^2)/(2g), s = (1 - g^2)/(1 + g xi), xi = 2u - 1. (The slides'
// 1/|2g| flips the sign of mu for g < 0.) That form cancels catastrophically as g -> 0, so we
// expand it: with t = 1 + g xi,
//   mu = [ xi + g (3 + xi^2 + 2 g xi + g^2 (xi^2 - 1)) / 2 ] / t^2,
// which is exact algebraically, equals xi (isotropic) at g = 0 and 1 at g = 1.
double sample_henyey_greenstein_cos(double g, double u);

// A direction scattered from the propagation direction d (unit) by HG with parameter g.
glm::dvec3 sample_henyey_greenstein(const glm::dvec3& d, double g, double u1, double u2);

// Rotates the unit vector d to the direction with cos(theta) = cos_theta from d and azimuth phi
// about it, (cos phi, sin phi) = azimuth (unit_circle), using a continuous orthonormal basis (no
// division by sin(theta), so d = +-z works).
glm::dvec3 rotate_direction(const glm::dvec3& d, double cos_theta, glm::dvec2 azimuth);

}  // namespace lamina
