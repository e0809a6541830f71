#include "materials/interfaces/diffuse_interface.h"

#include <algorithm>
#include <array>
#include <cmath>

#include "materials/interfaces/fresnel.h"

namespace lamina {
namespace {

constexpr int kPoints = 16;

// Gauss-Legendre roots and weights on [-1, 1] (Newton on P_n from Chebyshev guesses).
struct Rule {
  std::array<double, kPoints> x{}, w{};
  Rule() {
    for (int i = 0; i < kPoints; ++i) {
      double z = std::cos(kPi * (i + 0.75) / (kPoints + 0.5)), dp = 0.0;
      for (int it = 0; it < 100; ++it) {
        double p0 = 1.0, p1 = z;
        for (int l = 2; l <= kPoints; ++l) {
          const double p2 = ((2.0 * l - 1.0) * z * p1 - (l - 1.0) * p0) / l;
          p0 = p1;
          p1 = p2;
        }
        dp = kPoints * (z * p1 - p0) / (z * z - 1.0);
        const double dz = p1 / dp;
        z -= dz;
        if (std::abs(dz) < 1e-16) break;
      }
      x[i] = z;
      w[i] = 2.0 / ((1.0 - z * z) * dp * dp);
    }
  }
};

}  // namespace

// rbar = 2 int_0^1 F(mu) mu dmu. From the light side F is analytic in mu on [0, 1]: the refracted
// cosine sqrt(mu^2 + n^2 - 1) / n (n = n_t / n_i) has its branch points at mu = +-i sqrt(n^2 - 1),
// close to 0 only when the indices are close, so panels graded towards mu = 0, 16 Gauss-Legendre
// points each (1e-15 of the exact value; test DiffuseInterface.ReflectanceMatchesTheClosedForm).
// From the dense side, Stokes' relation 1 - rbar_hi = (n_lo / n_hi)^2 (1 - rbar_lo) (total
// internal reflection included) avoids the critical angle's square root.
double diffuse_fresnel_reflectance(double n_i, double n_t) {
  if (n_i == n_t) return 0.0;
  if (n_i > n_t) return 1.0 - (n_t / n_i) * (n_t / n_i) * (1.0 - diffuse_fresnel_reflectance(n_t, n_i));
  static const Rule rule;
  static constexpr std::array<double, 8> kCuts{0.0, 1e-3, 1e-2, 0.03, 0.1, 0.3, 0.6, 1.0};
  double sum = 0.0;
  for (std::size_t k = 0; k + 1 < kCuts.size(); ++k) {
    const double a = kCuts[k], h = 0.5 * (kCuts[k + 1] - a);
    for (int i = 0; i < kPoints; ++i) {
      const double mu = a + h * (rule.x[i] + 1.0);
      sum += h * rule.w[i] * 2.0 * mu * fresnel_dielectric(mu, n_i, n_t);
    }
  }
  return sum;
}

DiffuseInterface::DiffuseInterface(double n_a, double n_b)
    : n_lo(std::min(n_a, n_b)), n_hi(std::max(n_a, n_b)) {
  rbar_lo = diffuse_fresnel_reflectance(n_lo, n_hi);
  t_hi = (n_lo / n_hi) * (n_lo / n_hi) * (1.0 - rbar_lo);
}

double DiffuseInterface::fresnel(double mu_lo) const { return fresnel_dielectric(mu_lo, n_lo, n_hi); }

double DiffuseInterface::btdf_light_to_dense(double mu_lo) const { return (1.0 - fresnel(mu_lo)) / kPi; }

double DiffuseInterface::btdf_dense_to_light(double mu_lo) const {
  return (n_lo / n_hi) * (n_lo / n_hi) * (1.0 - fresnel(mu_lo)) / kPi;
}

double DiffuseInterface::brdf_dense() const { return (1.0 - t_hi) / kPi; }

glm::dvec3 DiffuseInterface::sample(const glm::dvec3& d, double n_from, Rng& rng) const {
  const double side = d.z < 0.0 ? -1.0 : 1.0;  // the sign of z beyond the interface
  auto cosine = [&](double sign) {
    glm::dvec3 w = sample_cosine_hemisphere({rng.uniform(), rng.uniform()});
    w.z *= sign;
    return w;
  };
  if (n_from == n_lo) {
    if (rng.uniform() < fresnel(std::abs(d.z))) return {d.x, d.y, -d.z};
    return cosine(side);
  }
  if (!(rng.uniform() < t_hi)) return cosine(-side);
  for (;;) {  // accepted with probability 1 - F: on average 1 / (1 - rbar_lo) tries (about 1.1)
    const glm::dvec3 w = cosine(side);
    if (rng.uniform() >= fresnel(std::abs(w.z))) return w;
  }
}

double DiffuseInterface::exit_pdf(double mu_lo) const {
  return n_lo == n_hi ? std::max(mu_lo, 0.0) / kPi : (1.0 - fresnel(mu_lo)) * std::max(mu_lo, 0.0) / (kPi * (1.0 - rbar_lo));
}

}  // namespace lamina
