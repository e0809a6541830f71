// A rough interface on the adding-doubling solver's basis: its reflection and transmission, from
// both sides, projected onto the azimuthal Fourier modes and the discrete directions of
// materials/adding_doubling/adding_doubling.h (the approach of Jakob, d'Eon, Jakob and Marschner,
// "A comprehensive framework for rendering layered materials", SIGGRAPH 2014, section 5; our
// own code and our solver's flux form). Derivation in interface_fourier.cpp and
// docs/adding_doubling.md, "Rough interfaces".
//
// Per interface: the projection takes the interface's alpha, the indices above and below and an
// eval function f(wo, wi) (microfacet.h's convention: directions point away from the surface,
// wi towards the light, the radiance BSDF with its n^2 factor in transmission), so that another
// microfacet model (e.g. one that conserves energy) plugs in by its eval alone.
#pragma once

#include <cstdint>
#include <functional>
#include <vector>

#include <glm/vec3.hpp>

namespace lamina {

// f(wo, wi) of the interface of roughness alpha between n_above (+z side) and n_below (-z side).
using InterfaceEval = std::function<double(double alpha, double n_above, double n_below, const glm::dvec3& wo,
                                           const glm::dvec3& wi)>;
// Today's single-scattering GGX dielectric (materials/interfaces/microfacet.h, RoughDielectric::eval).
double single_scattering_ggx_eval(double alpha, double n_above, double n_below, const glm::dvec3& wo,
                                  const glm::dvec3& wi);
// The energy-conserving microsurface's first order (materials/interfaces/microsurface.h,
// MicrosurfaceDielectric::eval_single): closed form. Its reflection is the single-scattering
// GGX reflection exactly (both use the height-correlated G2); its transmission has the Beta
// function's masking in place of G2.
double microsurface_single_eval(double alpha, double n_above, double n_below, const glm::dvec3& wo,
                                const glm::dvec3& wi);

// The solver's directions on one side of the interface: node k has cosine mu[k] and the cell
// [x_lo[k], x_hi[k]] in mu^2 that it stands for: outgoing power is gathered over the cell, and
// incoming power is spread evenly over it. x_lo == x_hi: a node of weight zero (a collimated
// beam of cosine mu[k]), which no power enters.
struct FourierDirections {
  std::vector<double> mu, x_lo, x_hi;
  int size() const { return static_cast<int>(mu.size()); }
};

// The four blocks of mode m, row-major: block(i, j) = the fraction of the power that arrives at
// the interface in direction j (a beam of unit power per unit area) and leaves in cell i, for
// radiance of azimuthal dependence cos(m dphi) (dphi the difference of the directions' azimuths
// of travel). Rt: above -> above (na x na), Td: above -> below (nb x na), Rb: below -> below
// (nb x nb), Tu: below -> above (na x nb).
struct InterfaceFourier {
  int modes = 0, above = 0, below = 0;
  std::vector<std::vector<double>> Rt, Td, Rb, Tu;  // [mode][i * columns + j]
  // project_microsurface only: the first order's part of Rt and Td (the rest is the light that
  // met the facets more than once).
  std::vector<std::vector<double>> Rt_single, Td_single;
  // project_microsurface only: over the columns, the largest energy correction |1 - first - higher|
  // (the first order's quadrature error and the walks' estimate of the higher orders together),
  // and the first order's share of a column, least and most.
  double largest_energy_correction = 0.0, smallest_single_albedo = 1.0, largest_single_albedo = 0.0;
};

struct InterfaceProjectionSettings {
  int cell_points = 4;   // Gauss-Legendre points in the polar angle per outgoing cell (and piece)
  int input_points = 2;  // the same over an incoming cell (a node of weight zero: its direction)
  int phi_panels = 12;  // at most: azimuth [0, pi] in panels halving towards pi (the specular
                        // side) until the last is alpha/4 wide
  int phi_points = 4;   // Gauss-Legendre points per panel
  // project_microsurface: microsurface walks per column (per incoming direction) for the orders
  // >= 2, and their seed (docs/adding_doubling.md, "Rough interfaces", for the error).
  int walks = 16384;
  std::uint64_t seed = 0x6d6963726f;
};

// The projection of the interface f (alpha, n_above, n_below) onto `modes` Fourier modes.
// Columns whose direction does not exist on their side (mu <= 0) are zero. The last few
// projections are kept by their exact inputs (a plain-function eval only): a repeated call
// returns the same numbers without projecting again.
InterfaceFourier project_interface(double alpha, double n_above, double n_below, const InterfaceEval& eval,
                                   const FourierDirections& above, const FourierDirections& below, int modes,
                                   const InterfaceProjectionSettings& settings = {});

// The columns of collimated beams from above (weight-zero directions: `beams`, their cells
// empty) into the cells of `above` (Rt: na x beams) and `below` (Td: nb x beams), apart from
// the projection of the nodes themselves, which is the same for every incidence and cached by
// project_interface.
struct BeamFourier {
  int modes = 0, beams = 0;
  std::vector<std::vector<double>> Rt, Td;  // [mode][i * beams + k]
  std::vector<std::vector<double>> Rt_single;  // project_microsurface_beams only (as InterfaceFourier's)
};
BeamFourier project_beams(double alpha, double n_above, double n_below, const InterfaceEval& eval,
                          const FourierDirections& beams, const FourierDirections& above,
                          const FourierDirections& below, int modes, const InterfaceProjectionSettings& settings = {});

// The energy-conserving interface (materials/interfaces/microsurface.h, Heitz et al. 2016), all
// orders: the first order projected as project_interface does (quadrature of
// microsurface_single_eval), the orders >= 2 -- smooth, broad and a small share -- estimated by
// `settings.walks` microsurface walks per column (MicrosurfaceDielectric::sample; incoming
// directions stratified over the column's cell), each walk of order >= 2
// binned into its outgoing cell with its cos(m dphi) moments. Fixed seeds: the same inputs give
// the same numbers on any thread count. Energy: the interface loses nothing, so each column's
// higher orders are scaled so that the column (both blocks, mode 0) sums to 1 exactly (the
// correction is InterfaceFourier::largest_energy_correction); reciprocity, which the walks hold
// only in the mean, by averaging each pair of reciprocal entries, alternately with the energy
// step. Cached as project_interface.
InterfaceFourier project_microsurface(double alpha, double n_above, double n_below, const FourierDirections& above,
                                      const FourierDirections& below, int modes,
                                      const InterfaceProjectionSettings& settings = {});
// Beams: the first order by quadrature at the beam's direction, the higher orders interpolated
// (linearly in mu^2) between the nodes' columns of project_microsurface (the same arguments, so
// its cached walks), each column then made to sum to 1.
BeamFourier project_microsurface_beams(double alpha, double n_above, double n_below, const FourierDirections& beams,
                                       const FourierDirections& above, const FourierDirections& below, int modes,
                                       const InterfaceProjectionSettings& settings = {});


}  // namespace lamina
