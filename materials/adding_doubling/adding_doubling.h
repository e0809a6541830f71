// The adding-doubling solution of the plane-parallel transport equation for a layer stack: the
// deterministic counterpart of the random walk (materials/walk/random_walk.h) for the energy totals
// and the BRDF/BTDF table.
//
// What it solves: the azimuthally averaged (Fourier m = 0) radiative transfer equation in every
// layer, with the layers' HG lobes, smooth Fresnel interfaces (the n^2 law of radiance and total
// internal reflection), rough interfaces (their BSDF projected onto the same basis:
// interface_fourier.h) or diffuse ones (materials/interfaces/diffuse_interface.h, built on the
// nodes: adding_doubling.cpp, 13.), a Lambert substrate or a semi-infinite last layer, exactly as the walk
// models the stack (materials/walk/random_walk.cpp). The m = 0 component carries all of the power, so
// it gives every total (reflected, transmitted, absorbed) for collimated incidence at any angle
// and for uniform diffuse incidence. The BRDF/BTDF on the bins of materials/brdf/brdf_table.h comes
// from the higher azimuthal Fourier modes, solved the same way (brdf_table_adding_doubling).
//
// Method (derivations in adding_doubling.cpp):
//  * Directions are discretised by Snell's invariant u = (n sin theta)^2, which every smooth
//    interface keeps, so one set of nodes serves every medium and each interface is a diagonal
//    operator; the u axis is cut at the squared indices of the media (so that the critical
//    angles fall on segment ends, as Prahl's split quadrature does) and each segment gets a
//    Gauss-Legendre rule in the cosine of its top medium.
//  * Operators act on the power (flux) carried by each node, so the n^2 scaling of radiance at
//    interfaces is implicit and a collimated beam is a node of quadrature weight zero.
//  * The forward peak of the HG lobes is treated by delta-M (Wiscombe 1977).
//  * Each layer starts from a thin layer by the diamond initialisation (Wiscombe 1976) and is
//    doubled to its thickness (van de Hulst 1980, ch. 4), or to convergence if semi-infinite;
//    layers and interfaces are combined by the adding equations (Prahl 1995; van de Hulst ch. 4).
// References: S. A. Prahl, "The adding-doubling method", in Optical-Thermal Response of
// Laser-Irradiated Tissue (Welch and van Gemert eds., 1995), ch. 5, and the iad program's
// documentation; H. C. van de Hulst, "Multiple Light Scattering" (1980); W. J. Wiscombe,
// "On initialization, error and flux conservation in the doubling method", JQSRT 16 (1976) 637;
// W. J. Wiscombe, "The delta-M method", J. Atmos. Sci. 34 (1977) 1408.
#pragma once

#include <vector>

#include "materials/adding_doubling/interface_fourier.h"
#include "materials/analytic/zeroth_order.h"
#include "materials/brdf/brdf_table.h"
#include "materials/base/spectrum.h"
#include "materials/stack/stack.h"

namespace lamina {

struct AddingDoublingSettings {
  // Gauss nodes in the first cosine segment (directions that exist in every medium); each further
  // segment gets a share in proportion to its cosine range (at least 2). The delta-M truncation
  // order of a layer is the number of its nodes (iad's choice).
  int quadrature_points = 16;
  // brdf_table_adding_doubling: fill the table's `single` with the analytic first order (else
  // single = 0 and multiple = value; the table mode does not need it).
  bool single_scattering_bins = true;
  // Solve this channel alone (0, 1, 2) and leave the others' totals (and bins) 0, a third of the
  // cost (lamina fit fits channels apart, materials/fit/stack_fit.h); -1: all.
  int only_channel = -1;
  // A rough top's BSDF, projected onto the solver's basis (interface_fourier.h): today's
  // single-scattering GGX dielectric, as the walk's rough top.
  InterfaceEval rough_eval = single_scattering_ggx_eval;
  // Energy-conserving rough interfaces (LayerStack::interface_model), what the bins of
  // brdf_table_adding_doubling hold: false, the light that scattered at least once (the walk's
  // bins; R_specular and T_ballistic are then the unscattered light, also where rough or diffuse interfaces
  // spread it); true (the table mode), everything but what the renderer adds exactly: the top's
  // first-order glossy reflection and the delta lobes of zeroth_order_above_rough.
  bool bins_hold_unscattered = false;
};

struct AddingDoublingTotals {
  // Collimated incidence from above at cos_theta_i: the five totals of EnergyTotals
  // (materials/brdf/brdf_table.h). R_specular and T_ballistic are the exact unscattered parts
  // (materials/analytic/zeroth_order); R_diffuse and T_diffuse are the solver's totals minus those, i.e.
  // the light that scattered at least once (the substrate's reflection counts as scattering);
  // absorbed = 1 - R - T.
  Spectrum R_specular, R_diffuse, T_ballistic, T_diffuse, absorbed;
  // Uniform diffuse incidence from above (equal radiance from every direction): the total
  // reflectance, transmittance and absorptance (unscattered light included in R and T).
  Spectrum R_hemispherical, T_hemispherical, absorbed_hemispherical;
  // Under a rough top: the part of R_hemispherical that is the top's own reflection (the glossy
  // lobe); 0 for a smooth top (whose unscattered part is zeroth_order's, exact).
  Spectrum R_hemispherical_glossy;
  // brdf_table_adding_doubling only: the power of the delta-M forward peak that it puts in the
  // bin of the mirror (R) and ballistic (T) direction (adding_doubling.cpp, 9.): a measure of
  // how much of the table's angular detail the truncation of the phase function blurs.
  Spectrum R_forward_peak, T_forward_peak;
  int nodes = 0;      // quadrature nodes per hemisphere over all media (without the incidence)
  int doublings = 0;  // doubling steps over all layers and channels
};

// The unscattered light of a stack with energy-conserving rough or diffuse interfaces that stays
// a delta lobe: the light that meets no rough or diffuse interface (the top's Fresnel reflection
// and the reflections of the smooth interfaces above the first rough or diffuse one), and a
// diffuse top's mirror reflection F(mu) from its less dense side; none under a rough top, and
// no ballistic transmission (it would cross a rough or diffuse interface). Other stacks:
// zeroth_order.
ZerothOrder zeroth_order_above_rough(const LayerStack& stack, double cos_theta_i);

// The totals of `stack` (validate_stack must accept it) for light from above at cos_theta_i in
// (0, 1]. Under a rough top, as in the walk's totals (materials/brdf/brdf_table.cpp): R_specular is
// the top's own reflection (the glossy lobe, not a delta), T_ballistic 0, R_diffuse and T_diffuse
// all light that entered the stack and left (adding_doubling.cpp, 10.). Throws
// std::invalid_argument for a cos_theta_i outside (0, 1] or a quadrature order below 2.
AddingDoublingTotals adding_doubling_totals(const LayerStack& stack, double cos_theta_i,
                                            const AddingDoublingSettings& settings = {});

// How much of the phase function the delta-M truncation at the order of `settings` leaves out,
// the largest over layers and channels: `forward`, the weight of the forward delta (the lobes
// with g > 0: sum w g^M, M the layer's number of nodes), which the totals handle exactly but the
// bins only as a peak in the mirror / ballistic bin; `backward`, the part of lobes with g < 0
// beyond order M (sum w |g|^M), which the truncated series represents badly (a backward peak
// is not truncated: its Legendre series oscillates, and the bins can go negative). The table
// mode uses adding-doubling only where both are small (materials/tables/layered_table.h).
struct DeltaMTruncation {
  double forward = 0.0, backward = 0.0;
};
DeltaMTruncation delta_m_truncation(const LayerStack& stack, const AddingDoublingSettings& settings = {});

// The totals at the order of `settings` and an estimate of their discretisation error: the
// absolute difference from the solution at half the order (a conservative estimate, since the
// error falls quickly with the order; see docs/validation.md, "Adding-doubling"). Where delta-M
// truncates a forward peak heavily (more than half of a scattering in the forward delta at half
// the order: g > 0.917 at 16 points in an index-matched layer, g > 0.952 in one of index 1.4,
// whose 8 points in the air's cone come with 6 beyond it), the error falls slowly and not monotonically, so the
// estimate extrapolates from N, N/2 and N/4 points instead (adding_doubling.cpp, 12.).
struct AddingDoublingEstimate {
  AddingDoublingTotals totals;
  AddingDoublingTotals error;  // per field (nodes, doublings: of N/2)
  // delta_m_truncation(...).forward at N/2 points; above kForwardPeakedTruncation the error is
  // the extrapolation from three orders.
  double forward_truncation = 0.0;
  bool extrapolated = false;
};
constexpr double kForwardPeakedTruncation = 0.5;
AddingDoublingEstimate adding_doubling_with_error(const LayerStack& stack, double cos_theta_i,
                                                  const AddingDoublingSettings& settings = {});

// The BRDF/BTDF table on the bins of `options` (theta_i, phi_i, bins_theta, bins_phi; samples and
// seed unused) and its totals, all orders, standard errors 0 (`lamina brdf --method
// adding-doubling`). `single` is the analytic first order (brdf_table_first_order) and
// `multiple` = value - single. Cost: one solution per Fourier mode and channel (the modes up to
// the delta-M order, about the number of nodes). The delta-M forward peak's power is put in the
// bin of the mirror / ballistic direction (adding_doubling.cpp, 9.), so the bins' power equals
// R_diffuse and T_diffuse. Under a rough top the bins hold the light that entered the stack (as
// the walk's), `single` is 0, there is no forward peak, and the bins' power is R_diffuse up to
// their cosine quadrature (~1e-3). *totals (optional) receives the totals with the
// diffuse-incidence ones.
BrdfTable brdf_table_adding_doubling(const LayerStack& stack, const BrdfOptions& options,
                                     const AddingDoublingSettings& settings = {},
                                     AddingDoublingTotals* totals = nullptr);
// The same for several incidences at once (options.theta_i_deg is replaced by each of
// theta_i_deg): one solution serves them all (each incidence is one more node of weight zero),
// so a table of 9 incidences costs about twice one incidence.
std::vector<BrdfTable> brdf_tables_adding_doubling(const LayerStack& stack, const BrdfOptions& options,
                                                   const std::vector<double>& theta_i_deg,
                                                   const AddingDoublingSettings& settings = {},
                                                   std::vector<AddingDoublingTotals>* totals = nullptr);

}  // namespace lamina
