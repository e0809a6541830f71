// Smooth dielectric interfaces: Fresnel reflectance for unpolarised light and Snell's law.
//
// pbrt-v4 section 9.3.2 (FrDielectric), Born and Wolf section 1.5. The radiance transmitted from
// index n_i into index n_t is scaled by (n_t/n_i)^2 (the n^2 law of radiance: Veach's thesis,
// section 5.2): that factor is applied where radiance crosses an interface, never here.
#pragma once

#include <glm/vec3.hpp>

namespace lamina {

// Reflectance of unpolarised light arriving at the interface with |cos(theta_i)| = cos_theta_i
// (taken by absolute value) from a medium of index n_i onto one of index n_t.
// Exact: 0 when n_i == n_t, ((n_t-n_i)/(n_t+n_i))^2 at normal incidence, 1 at grazing
// incidence and under total internal reflection.
double fresnel_dielectric(double cos_theta_i, double n_i, double n_t);

// |cos(theta_t)| of the refracted direction by Snell's law, or a negative value under total
// internal reflection (also exactly at the critical angle). Computed as (1 - eta^2) + eta^2 cos^2
// to keep relative precision at grazing incidence; exact when n_i == n_t.
double refracted_cos(double cos_theta_i, double n_i, double n_t);

// The propagation direction d (unit) crossing a plane z = const from index n_i into n_t: the
// tangential part scales by n_i/n_t and the z part keeps its sign (Snell's law in vector form).
// Returns false under total internal reflection (d unchanged). Index-matched (n_i == n_t): d
// unchanged, true.
bool refract_through_plane(glm::dvec3* d, double n_i, double n_t);

// Mirror reflection of the propagation direction d at a plane z = const.
inline glm::dvec3 reflect_at_plane(const glm::dvec3& d) { return {d.x, d.y, -d.z}; }

}  // namespace lamina
