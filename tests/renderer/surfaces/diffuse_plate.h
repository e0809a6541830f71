// The closed forms of a plate with diffuse faces (materials/interfaces/diffuse_interface.h) that
// absorbs and does not scatter, shared by the surface and render tests. Light inside is a beam of
// cosine-distributed directions wherever a diffuse face made it (the crossing from air, or the
// Lambertian reflection 1 - t_hi from inside); a smooth face reflects it specularly, keeping each
// direction. So every quantity is a geometric series in one-dimensional integrals over the cosine
// mu (density 2 mu dmu) of the attenuation a = exp(-k / mu), k the plate's optical thickness: with
// two diffuse faces, PROSPECT's plate (Allen et al. 1969).
#pragma once

#include <cmath>
#include <functional>
#include <utility>

#include <glm/vec3.hpp>

#include "materials/analytic/first_order.h"  // gauss_legendre
#include "materials/base/sampling.h"
#include "materials/interfaces/diffuse_interface.h"
#include "materials/interfaces/fresnel.h"
#include "materials/stack/stack.h"

namespace lamina::test {

inline constexpr double kN = 1.45;

// integral_0^1 f(mu) dmu, Gauss-Legendre on [0, split] and [split, 1] (split: a kink, the
// critical angle).
inline double integrate_mu(const std::function<double(double)>& f, double split = 0.5) {
  constexpr int kNodes = 200;
  double x[kNodes], w[kNodes], sum = 0.0;
  for (const auto& [a, b] : {std::make_pair(0.0, split), std::make_pair(split, 1.0)}) {
    gauss_legendre(kNodes, a, b, x, w);
    for (int i = 0; i < kNodes; ++i) sum += w[i] * f(x[i]);
  }
  return sum;
}

// A slab of index kN in air that absorbs (sigma_a per channel) and does not scatter, with a
// diffuse top, bottom, or both.
struct Plate {
  bool top = true, bottom = false;
  Spectrum sigma_a{0.5, 2.0, 8.0};
  double thickness = 0.2;
};

inline LayerStack plate_stack(const Plate& p) {
  LayerStack s;
  s.layers.push_back(make_layer("plate", kN, p.thickness, p.sigma_a, Spectrum(0.0), Spectrum(0.0)));
  s.below.ior = 1.0;
  s.top_diffuse = p.top;
  s.layers[0].bottom_diffuse = p.bottom;
  return s;
}

// The plate's closed forms in channel c for the viewer at wo (the light's path reversed: the same
// by reciprocity, air on both sides), per unit incident power.
struct PlateOptics {
  double specular = 0.0;     // the mirror reflection (the delta lobe)
  double reflected = 0.0;    // the rest of the reflectance
  double transmitted = 0.0;
  // f |cos| towards an outside direction above (w.z > 0) or below.
  std::function<double(const glm::dvec3&)> f_cos;
};

inline PlateOptics plate_optics(const Plate& p, const glm::dvec3& wo, int c) {
  const double k = p.sigma_a[c] * p.thickness;
  const DiffuseInterface face(1.0, kN);
  const double t = face.t_hi, f_o = face.fresnel(wo.z);
  const double split = std::sqrt(1.0 - 1.0 / (kN * kN));  // the critical cosine inside
  auto a = [k](double mu) { return std::exp(-k / mu); };
  auto f_in = [](double mu) { return fresnel_dielectric(mu, kN, 1.0); };
  // A cosine beam of unit power inside: what reaches the other face (pass), what leaves through
  // it when it is smooth (out) and what the smooth face sends back to the first one (back).
  const double pass = integrate_mu([&](double mu) { return 2.0 * mu * a(mu); }, split);
  const double out = integrate_mu([&](double mu) { return 2.0 * mu * a(mu) * (1.0 - f_in(mu)); }, split);
  const double back = integrate_mu([&](double mu) { return 2.0 * mu * a(mu) * a(mu) * f_in(mu); }, split);
  // f |cos| of a cosine beam of unit power leaving straight through a smooth face towards w:
  // density mu / pi inside, times d(omega_in) / d(omega_out) = |w.z| / (n^2 mu), over one pass.
  auto direct = [=](const glm::dvec3& w) {
    const double mu = refracted_cos(w.z, 1.0, kN);
    return std::abs(w.z) / (kN * kN * kPi) * a(mu) * (1.0 - f_in(mu));
  };
  PlateOptics o;
  o.specular = f_o;
  if (p.top && p.bottom) {
    const double t_in = 1.0 - f_o, series = 1.0 / (1.0 - (1.0 - t) * (1.0 - t) * pass * pass);
    o.transmitted = t_in * pass * t * series;
    o.reflected = t_in * (1.0 - t) * pass * pass * t * series;
  } else if (p.top) {  // the beam returns to the top with `back`, which reflects 1 - t of it again
    const double t_in = 1.0 - f_o, series = 1.0 / (1.0 - (1.0 - t) * back);
    o.transmitted = t_in * out * series;
    o.reflected = t_in * back * t * series;
    o.f_cos = [=](const glm::dvec3& w) { return w.z > 0.0 ? o.reflected * face.exit_pdf(w.z) : t_in * series * direct(w); };
    return o;
  } else {  // smooth top: the refracted beam reaches the diffuse bottom, whose reflection is a cosine beam up
    const double mu_t = refracted_cos(wo.z, 1.0, kN), arrives = (1.0 - f_o) * a(mu_t);
    const double series = 1.0 / (1.0 - (1.0 - t) * back);
    o.transmitted = arrives * t * series;
    o.reflected = arrives * (1.0 - t) * out * series;
    o.f_cos = [=](const glm::dvec3& w) { return w.z > 0.0 ? arrives * (1.0 - t) * series * direct(w) : o.transmitted * face.exit_pdf(-w.z); };
    return o;
  }
  o.f_cos = [=](const glm::dvec3& w) { return (w.z > 0.0 ? o.reflected : o.transmitted) * face.exit_pdf(std::abs(w.z)); };
  return o;
}

}  // namespace lamina::test
