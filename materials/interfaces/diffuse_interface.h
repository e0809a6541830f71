// A diffuse interface: a plane between indices n_lo < n_hi (either side may be above) that
// reflects light arriving from the less dense side specularly and transmits it into a
// cosine-distributed (Lambertian) direction on the dense side. The surface of PROSPECT's plate
// (Allen, Gausman, Richardson and Thomas 1969; Jacquemoud and Baret 1990): light that has
// entered the plate is isotropic. docs/adding_doubling.md, "Diffuse interfaces", and
// docs/random_walk.md, "Diffuse interfaces", for how the solver and the walk use it.
//
// Derivation. Light side, incidence cosine mu_lo: specular reflection F(mu_lo) (Fresnel,
// unpolarised), transmission 1 - F(mu_lo) spread by Lambert's law, so the BTDF is
//     f(lo -> hi) = (1 - F(mu_lo)) / pi.
// Reciprocity across an index step (f(i -> o) / n_o^2 = f(o -> i) / n_i^2: Veach's thesis,
// eq. 5.14) fixes the other direction:
//     f(hi -> lo) = (n_lo / n_hi)^2 (1 - F(mu_lo)) / pi,
// whose total from ANY dense-side direction, int f mu_lo d(omega_lo), is the constant
//     t_hi = (n_lo / n_hi)^2 (1 - rbar_lo),   rbar_lo = 2 int_0^1 F(mu) mu dmu
// (Stokes' relation between the diffuse transmittances of the two sides: PROSPECT's
// t21 = tav(90, n) / n^2), into light-side directions of density
//     p(omega_lo) = (1 - F(mu_lo)) mu_lo / (pi (1 - rbar_lo)).
// The dense side keeps 1 - t_hi. PROSPECT's plate sums the bounces inside it as if every pass
// met isotropic light (R = r_alpha + r21 tau T with the same tau = 2 E3(k) each time), which is
// exact only if the dense side REFLECTS diffusely too: a specular reflection would keep the
// e^(-k/mu) shape of the light that crossed an absorbing interior, and the next pass would
// transmit less than tau (by up to 0.01 in R and T of one plate; docs/adding_doubling.md). So
// the dense side reflects 1 - t_hi by Lambert's law,
//     f_r(hi -> hi) = (1 - t_hi) / pi,
// reciprocal and, with the transmission, energy-conserving from every direction on both sides.
#pragma once

#include <glm/vec3.hpp>

#include "materials/base/sampling.h"

namespace lamina {

// 2 int_0^1 F(mu) mu dmu: the reflectance of the interface n_i | n_t for diffuse (isotropic)
// light arriving from the side of index n_i (total internal reflection included when n_i > n_t).
double diffuse_fresnel_reflectance(double n_i, double n_t);

struct DiffuseInterface {
  DiffuseInterface() = default;
  // The indices of the two sides in either order; equal indices are no interface (t_hi = 1).
  DiffuseInterface(double n_a, double n_b);

  double n_lo = 1.0, n_hi = 1.0;
  double rbar_lo = 0.0;  // diffuse_fresnel_reflectance(n_lo, n_hi)
  double t_hi = 1.0;     // (n_lo / n_hi)^2 (1 - rbar_lo): transmittance from the dense side

  // F(mu_lo): the specular reflectance on the light side at cosine mu_lo.
  double fresnel(double mu_lo) const;
  // The BTDFs (radiance, per steradian, cosines not included) in terms of the LIGHT side's cosine.
  double btdf_light_to_dense(double mu_lo) const;
  double btdf_dense_to_light(double mu_lo) const;
  // The dense side's (Lambertian) reflection.
  double brdf_dense() const;
  // The density per steradian of the light-side direction of cosine mu_lo for light transmitted
  // from the dense side.
  double exit_pdf(double mu_lo) const;

  // What the interface does to light propagating along d (unit, d.z != 0) that meets it from the
  // side of index n_from (n_lo or n_hi): the new propagation direction, on the far side
  // (transmitted: the same sign of z as d) or back (reflected). Light side: specular reflection
  // with probability F(|d.z|), else a cosine-distributed direction beyond. Dense side:
  // transmission with probability t_hi, its direction cosine-distributed and kept with
  // probability 1 - F (rejection: density (1 - F) mu / (pi (1 - rbar_lo)), exit_pdf), else a
  // cosine-distributed reflection. Every branch has weight 1 (the probabilities are the
  // interface's own). Deterministic in rng.
  glm::dvec3 sample(const glm::dvec3& d, double n_from, Rng& rng) const;
};

}  // namespace lamina
