// BRDF/BTDF tables and energy totals of a layer stack, estimated by the random walk
// (`lamina brdf --method monte-carlo`, docs/contracts.md).
//
// Binning: K bins uniform in |cos(theta_o)| per hemisphere and M bins uniform in phi_o, so every
// bin has the same solid angle 2 pi / (K M). phi_o is the azimuth of wo measured from the light's
// azimuth phi_i: phi_o = 0 on the light's side (back scattering), 180 the mirror side.
//
// Bin value: a walk that leaves with weight W in direction w carries the fraction W of the
// incident power. The power leaving per unit irradiance into a set of directions B is
//   P(B) = integral_B f(wi, w) |cos theta| dw,
// so (1/N) sum_{exits in B} W estimates P(B), and
//   value(B) = P(B) / Omega_proj(B),  Omega_proj(B) = integral_B |cos theta| dw
//            = (mu_hi^2 - mu_lo^2)/2 * dphi,
// is the BRDF (BTDF) averaged over the bin weighted by projected solid angle (docs/contracts.md).
// Standard errors come from per-photon sums of squares: a photon adds to at most one bin.
#pragma once

#include <cstdint>
#include <vector>

#include <glm/vec3.hpp>

#include "materials/walk/random_walk.h"
#include "materials/base/spectrum.h"
#include "materials/stack/stack.h"

namespace lamina {

struct BrdfOptions {
  double theta_i_deg = 0.0;
  double phi_i_deg = 0.0;
  std::uint64_t samples = 100000;
  int bins_theta = 18;  // K
  int bins_phi = 36;    // M
  std::uint64_t seed = 1;
  WalkOptions walk;
  // Monte Carlo: called (from any thread) with the number of photons just finished, every few
  // thousand photons; may be empty.
  std::function<void(std::uint64_t)> on_progress;
};

// The direction towards the light for (theta_i, phi_i) in degrees.
glm::dvec3 incident_direction(double theta_i_deg, double phi_i_deg);

// The azimuth bin (0..bins-1) of an outside direction (x, y, .) relative to phi_i (radians):
// phi = atan2(y, x) - phi_i reduced to [0, 2 pi), bin floor(phi / (2 pi) bins). Computed with an
// approximate atan2 wherever that cannot change the bin (every photon of `lamina brdf` is binned).
int azimuth_bin(double x, double y, double phi_i, int bins);

struct Estimate {
  Spectrum value;
  Spectrum stderr_;  // standard error of value
};

// The five totals of docs/contracts.md (fractions of the incident power, per channel).
// R_specular and T_ballistic are the analytic zeroth order (materials/analytic/zeroth_order: exact, zero
// standard error); R_diffuse and T_diffuse are the walks' exits after at least one scattering
// event; absorbed is, photon by photon, 1 minus the other four, so the five sum to 1 by
// construction and absorbed is still an unbiased estimator (with the diffuse parts' noise).
struct EnergyTotals {
  Estimate R_specular, R_diffuse, T_ballistic, T_diffuse, absorbed;
  // Independent Monte Carlo estimates of the same quantities, for tests: the walk's direct tally
  // of absorption, and its unscattered exits (top Fresnel reflection included) as delta parts.
  Estimate absorbed_direct, R_specular_walk, T_ballistic_walk;
  // Power carried by walks still running after WalkOptions::forced_exponential_after
  // interactions (WalkResult::cut_weight; Monte Carlo only): the part of the answer that the
  // final roulette makes a lottery of. Up to this much may be missing from R and T (and appear
  // in absorbed) beyond their standard errors.
  Estimate unresolved;
  std::uint64_t unresolved_walks = 0;
};

enum class BrdfSide { Reflect = 0, Transmit = 1 };

struct BrdfTable {
  BrdfOptions options;
  EnergyTotals totals;
  // Per bin and channel, indexed by bin_index(side, k, m): value = single + multiple.
  std::vector<Spectrum> value, stderr_, single, multiple;
  std::vector<Spectrum> single_stderr;  // standard error of `single` (Monte Carlo only)
  // How the walks ended, indexed by WalkResult::End.
  std::vector<std::uint64_t> ends;

  int bin_index(BrdfSide side, int k, int m) const {
    return (static_cast<int>(side) * options.bins_theta + k) * options.bins_phi + m;
  }
  // Bin k spans |cos theta| in [k/K, (k+1)/K]; centres are those of the cos and phi ranges.
  double theta_centre_deg(int k) const;
  double phi_centre_deg(int m) const;
  double projected_solid_angle(int k) const;
};

// Monte Carlo table: options.samples walks, photon i using Rng(seed, i); identical bits for any
// number of threads (fixed partition into blocks, reduced in block order).
BrdfTable brdf_table_monte_carlo(const LayerStack& stack, const BrdfOptions& options);

// The analytic table (`--method first-order`): value = single = the first-order BRDF/BTDF
// (materials/analytic/first_order) averaged over each bin weighted by projected solid angle (n x n points
// per bin: Gauss-Legendre in |cos|^2, midpoint rule in phi), stderr 0, multiple 0.
// Totals: R_specular and T_ballistic from zeroth_order; R_diffuse and T_diffuse the first-order
// albedos; absorbed = 1 - the others, i.e. the absorbed light PLUS the light of two and more
// scattering events that first order leaves out (so that the five still sum to 1).
// diffuse_totals = false leaves R_diffuse and T_diffuse 0 and absorbed = 1 - R_specular -
// T_ballistic: their quadrature (first_order_albedo, 48 x 96 directions) costs about as much as
// the bins of a 6 x 12 table, and a caller of the bins alone (auto's prediction) does not need it.
BrdfTable brdf_table_first_order(const LayerStack& stack, const BrdfOptions& options, int n = 6,
                                 bool diffuse_totals = true);

// The "next event" estimator of f(wi, wo) (BRDF if wo.z > 0, BTDF if wo.z < 0) at given outside
// directions: the average over walks of sum_events throughput * connection_weight_all_paths(wo).
// An estimator independent of the bin counts (it never uses the exits). With the walk's
// similarity option (WalkOptions::similarity_after, similar) the events after the switch connect
// through the similar stack.
struct PointEstimate {
  Estimate total, single;  // single: events of order 1 only
};
std::vector<PointEstimate> brdf_connection_estimate(const LayerStack& stack, const glm::dvec3& wi,
                                                    const std::vector<glm::dvec3>& wo,
                                                    std::uint64_t samples, std::uint64_t seed,
                                                    const WalkOptions& walk = {});

// The same estimator averaged over each bin of a table (for every event, one direction drawn in
// every bin uniformly in projected solid angle: |cos|^2 uniform, phi uniform), so that it
// estimates exactly what the bin counts estimate. Fills value, stderr_, single, multiple.
BrdfTable brdf_table_connection(const LayerStack& stack, const BrdfOptions& options);

}  // namespace lamina
