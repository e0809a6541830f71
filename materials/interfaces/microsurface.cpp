#include "materials/interfaces/microsurface.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>

#include <glm/geometric.hpp>

#include "materials/interfaces/fresnel.h"
#include "materials/interfaces/microsurface_first_order.h"

namespace lamina {
namespace {

constexpr double kEscaped = std::numeric_limits<double>::infinity();

// The uniform height distribution of Heitz et al. 2016 (their section 4.1): its CDF and inverse.
double c1(double h) { return std::clamp(0.5 * (h + 1.0), 0.0, 1.0); }
double inv_c1(double u) { return std::clamp(2.0 * u - 1.0, -1.0, 1.0); }

// The projected area of the microsurface seen from v (any direction, unit):
// A(v) = integral max(0, v.m) D(m) dm = (sqrt(v.z^2 + alpha^2 (v.x^2 + v.y^2)) + v.z) / 2, i.e.
// v.z (1 + Lambda(v)) above the horizon and |v.z| Lambda(v) below it (Heitz 2014, eqs. 17, 86);
// written without the cancellation below the horizon.
double projected_area(double alpha, const glm::dvec3& v) {
  const double s2 = alpha * alpha * (v.x * v.x + v.y * v.y);
  const double root = std::sqrt(v.z * v.z + s2);
  return v.z >= 0.0 ? 0.5 * (root + v.z) : 0.5 * s2 / (root - v.z);
}

// The next height at which a ray at height h moving along w meets the microsurface, or kEscaped
// (Heitz et al. 2016, section 4.3): going up, it escapes with probability G1(w, h) = C1(h)^Lambda
// and otherwise meets it where C1 = C1(h) / (1 - u)^(1/Lambda); going down, it always meets it,
// where C1 = C1(h) (1 - u)^(1/(1 + Lambda)).
double next_height(const GgxDistribution& g, const glm::dvec3& w, double h, double u) {
  if (w.z == 0.0) return h;  // along the mean plane: measure zero
  const double lambda = g.lambda(w);
  if (w.z > 0.0) {
    if (!(lambda > 0.0)) return kEscaped;
    const double g1 = std::pow(c1(h), lambda);
    if (1.0 - u < g1) return kEscaped;
    return inv_c1(c1(h) / std::pow(1.0 - u, 1.0 / lambda));
  }
  return inv_c1(c1(h) * std::pow(1.0 - u, 1.0 / (1.0 + lambda)));
}

// The probability that a ray leaving height h along w (w.z > 0) meets nothing: C1(h)^Lambda(w).
double escape(const GgxDistribution& g, const glm::dvec3& w, double h) {
  if (!(w.z > 0.0)) return 0.0;
  return std::pow(c1(h), g.lambda(w));
}

// A visible normal of the microsurface (m.z > 0) seen from v, v on EITHER side: density
// max(0, v.m) D(m) / A(v). Dupuy and Benyoub, "Sampling Visible GGX Normals with Spherical Caps"
// (HPG 2023): in the configuration stretched to alpha = 1 the visible normals of the hemisphere
// are the half vectors normalize(v + c) of c uniform on the spherical cap c.z > -v.z (reflecting
// v about m gives c, whose Jacobian 4 |v.m| makes the density proportional to v.m), which holds
// below the horizon too, where Heitz 2018's disk sampler of microfacet.h does not apply.
glm::dvec3 sample_visible_any(double alpha, const glm::dvec3& v, double u0, double u1) {
  const glm::dvec3 vs = glm::normalize(glm::dvec3(alpha * v.x, alpha * v.y, v.z));
  const glm::dvec2 azimuth = unit_circle(u0);
  const double z = (1.0 - u1) * (1.0 + vs.z) - vs.z;
  const double s = std::sqrt(std::max(0.0, 1.0 - z * z));
  const glm::dvec3 h = glm::dvec3(s * azimuth.x, s * azimuth.y, z) + vs;
  return glm::normalize(glm::dvec3(alpha * h.x, alpha * h.y, std::max(h.z, 1e-300)));
}

// The microsurface's phase function at a scattering: the density (per solid angle of b) that a
// ray arriving from v (pointing away from the facets, either side of the mean plane) leaves
// along b, in the frame where the ray's medium (index n_out) is +z: a visible facet m from v,
// then reflection (b.z > 0 side: F D_v(m) / (4 v.m), Walter eq. 14) or refraction into n_in
// (b on the far side of m: (1 - F) D_v(m) n_in^2 |b.m| / (n_out v.m + n_in b.m)^2, eq. 17).
// `area`: projected_area(g.alpha, v), which callers with a fixed v compute once.
double phase(const GgxDistribution& g, const glm::dvec3& v, const glm::dvec3& b, double n_out, double n_in, double area) {
  if (!(area > 0.0)) return 0.0;
  if (b.z > 0.0) {
    const glm::dvec3 sum = v + b;
    const double len = glm::length(sum);
    if (!(len > 0.0)) return 0.0;
    const glm::dvec3 m = sum / len;
    const double vm = glm::dot(v, m);
    if (!(m.z > 0.0) || !(vm > 0.0)) return 0.0;
    return fresnel_dielectric(vm, n_out, n_in) * g.d(m) / (4.0 * area);
  }
  if (n_out == n_in) return 0.0;
  glm::dvec3 m = -(n_out * v + n_in * b);
  const double len = glm::length(m);
  if (!(len > 0.0)) return 0.0;
  m /= len;
  if (m.z < 0.0) m = -m;
  const double vm = glm::dot(v, m), bm = glm::dot(b, m);
  if (!(vm > 0.0) || !(bm < 0.0)) return 0.0;
  const double denom = n_out * vm + n_in * bm;
  return (1.0 - fresnel_dielectric(vm, n_out, n_in)) * vm * g.d(m) / area * n_in * n_in * -bm / (denom * denom);
}

double phase(const GgxDistribution& g, const glm::dvec3& v, const glm::dvec3& b, double n_out, double n_in) {
  return phase(g, v, b, n_out, n_in, projected_area(g.alpha, v));
}

// B(x, y) = Gamma(x) Gamma(y) / Gamma(x + y), 0 if an argument is infinite (grazing), with
// lgamma_x = lgamma(x) given (a caller's x is fixed).
double beta_function(double x, double lgamma_x, double y) {
  if (!std::isfinite(x) || !std::isfinite(y)) return 0.0;
  return std::exp(lgamma_x + std::lgamma(y) - std::lgamma(x + y));
}

// The walk's state in the frame where the side the ray is on is +z: the frame is the caller's
// times `sign` while the ray is on the side it arrived from, and flips (w -> -w, h -> -h, the
// indices swap) at each refraction (Heitz et al. 2016, section 5.2).
struct Walker {
  const GgxDistribution& g;
  double n_out, n_in;
  double sign;          // +1 if the arrival side is +z
  bool on_arrival_side = true;
  glm::dvec3 w;         // propagation direction
  double h = 1.0;       // C1(1) = 1: the ray starts above every facet

  Walker(const MicrosurfaceDielectric& s, const glm::dvec3& from)
      : g(s.distribution), n_out(from.z > 0.0 ? s.n_above : s.n_below), n_in(from.z > 0.0 ? s.n_below : s.n_above),
        sign(from.z > 0.0 ? 1.0 : -1.0), w(-from * (from.z > 0.0 ? 1.0 : -1.0)) {}

  // A direction of the caller's frame in the current one.
  glm::dvec3 local(const glm::dvec3& d) const { return on_arrival_side ? d * sign : -d * sign; }

  // Scatters at the current height: a visible facet, then reflection or refraction.
  void scatter(Rng& rng) {
    const glm::dvec3 v = -w;
    const double u0 = rng.uniform(), u1 = rng.uniform(), u_choice = rng.uniform();
    const glm::dvec3 m = sample_visible_any(g.alpha, v, u0, u1);
    const double vm = std::max(0.0, glm::dot(v, m));
    glm::dvec3 t;
    if (u_choice < fresnel_dielectric(vm, n_out, n_in) || !refract_about(v, m, n_out, n_in, &t)) {
      w = 2.0 * vm * m - v;
      return;
    }
    w = -t;  // the far side becomes +z
    h = -h;
    std::swap(n_out, n_in);
    on_arrival_side = !on_arrival_side;
  }
};

}  // namespace

bool MicrosurfaceDielectric::sample(const glm::dvec3& from, Rng& rng, glm::dvec3* to, int* order) const {
  Walker walker(*this, from);
  for (int k = 0; k <= kMaxOrder; ++k) {
    walker.h = next_height(distribution, walker.w, walker.h, rng.uniform());
    if (walker.h == kEscaped) {
      *to = walker.local(walker.w);  // local() is its own inverse
      if (order) *order = k;
      return true;
    }
    if (k == kMaxOrder) break;
    walker.scatter(rng);
  }
  if (order) *order = kMaxOrder + 1;
  return false;
}

double MicrosurfaceDielectric::density_single(const glm::dvec3& from, const glm::dvec3& to) const {
  return MicrosurfaceFirstOrder(*this, from).density(to);
}

MicrosurfaceFirstOrder::MicrosurfaceFirstOrder(const MicrosurfaceDielectric& s, const glm::dvec3& from)
    : distribution_(s.distribution), grazing_(from.z == 0.0), sign_(from.z > 0.0 ? 1.0 : -1.0),
      n_out_(from.z > 0.0 ? s.n_above : s.n_below), n_in_(from.z > 0.0 ? s.n_below : s.n_above), a_(from * sign_),
      lambda_a_(grazing_ ? 0.0 : distribution_.lambda(a_)), area_a_(projected_area(distribution_.alpha, a_)) {}

double MicrosurfaceFirstOrder::beta(double lambda_b) {
  if (lambda_b == last_lambda_b_) return last_beta_;
  if (!has_lgamma_a_) {
    lgamma_a_ = std::lgamma(1.0 + lambda_a_);
    has_lgamma_a_ = true;
  }
  last_lambda_b_ = lambda_b;
  last_beta_ = beta_function(1.0 + lambda_a_, lgamma_a_, 1.0 + lambda_b);
  return last_beta_;
}

double MicrosurfaceFirstOrder::density(const glm::dvec3& to) {
  if (grazing_ || to.z == 0.0) return 0.0;
  const glm::dvec3 b = to * sign_;
  // The first scattering's phase function, averaged over the height of the first hit
  // (C1 = u^(1/(1 + Lambda_a))) times the escape towards b from there (Heitz et al. 2016,
  // section 5.1): (1 + Lambda_a) / (1 + Lambda_a + Lambda_b) above, (1 + Lambda_a) B(1 +
  // Lambda_a, 1 + Lambda_b) through.
  const double la = lambda_a_, lb = distribution_.lambda(b);
  const double escape_mean = b.z > 0.0 ? (1.0 + la) / (1.0 + la + lb) : (1.0 + la) * beta(lb);
  return phase(distribution_, a_, b, n_out_, n_in_, area_a_) * escape_mean;
}

double MicrosurfaceDielectric::density(const glm::dvec3& from, const glm::dvec3& to, Rng& rng) const {
  double p = density_single(from, to);
  if (from.z == 0.0 || to.z == 0.0) return p;
  Walker walker(*this, from);
  for (int k = 0; k < kMaxOrder; ++k) {
    walker.h = next_height(distribution, walker.w, walker.h, rng.uniform());
    if (walker.h == kEscaped) break;
    if (k > 0) {
      // Next-event estimation: scatter towards `to` and leave from this height (on the far side
      // the height is mirrored).
      const glm::dvec3 b = walker.local(to);
      const double ph = phase(distribution, -walker.w, b, walker.n_out, walker.n_in);
      if (ph > 0.0) p += ph * (b.z > 0.0 ? escape(distribution, b, walker.h) : escape(distribution, -b, -walker.h));
    }
    walker.scatter(rng);
  }
  return p;
}

double MicrosurfaceDielectric::eval_single(const glm::dvec3& wo, const glm::dvec3& wi) const {
  return wo.z == 0.0 ? 0.0 : density_single(wi, wo) / std::abs(wo.z);
}

double MicrosurfaceDielectric::eval(const glm::dvec3& wo, const glm::dvec3& wi, Rng& rng) const {
  return wo.z == 0.0 ? 0.0 : density(wi, wo, rng) / std::abs(wo.z);
}

double rough_interface_bsdf(InterfaceModel model, double alpha, double n_above, double n_below,
                            const glm::dvec3& wo, const glm::dvec3& wi, int samples, std::uint64_t seed) {
  if (model == InterfaceModel::SingleScattering) return RoughDielectric{{alpha}, n_above, n_below}.eval(wo, wi);
  const MicrosurfaceDielectric surface{{alpha}, n_above, n_below};
  if (samples <= 0) return surface.eval_single(wo, wi);
  // The stream is keyed on the directions: the same query, the same value.
  std::uint64_t key = 0;
  for (double x : {wo.x, wo.y, wo.z, wi.x, wi.y, wi.z}) {
    std::uint64_t bits;
    std::memcpy(&bits, &x, sizeof bits);
    key = mix64(key ^ bits);
  }
  Rng rng(seed, key);
  double sum = 0.0;
  for (int i = 0; i < samples; ++i) sum += surface.eval(wo, wi, rng);
  return sum / samples;
}

}  // namespace lamina
