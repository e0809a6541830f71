// The walk's totals and adding-doubling's at one incidence, for the tests that hold one against
// the other (test_adding_doubling, test_rough_adding_doubling, test_energy_conserving_adding_doubling).
#pragma once

#include <cmath>
#include <cstdint>
#include <string>

#include <gtest/gtest.h>

#include "materials/adding_doubling/adding_doubling.h"
#include "materials/brdf/brdf_table.h"
#include "tests/support/statistics.h"

namespace lamina::test {

struct WalkAndSolver {
  BrdfTable walk;                 // totals only (one bin)
  AddingDoublingEstimate solver;  // with its discretisation error estimate
};

inline WalkAndSolver walk_and_solver(const LayerStack& s, double theta_deg, std::uint64_t samples) {
  BrdfOptions o;
  o.theta_i_deg = theta_deg;
  o.samples = samples;
  o.bins_theta = 1;
  o.bins_phi = 1;
  return {brdf_table_monte_carlo(s, o), adding_doubling_with_error(s, std::cos(theta_deg * M_PI / 180.0))};
}

// The walk's totals against the solver's, one channel: R_diffuse, T_diffuse and absorbed within z
// of the walk's standard errors plus the solver's estimate and the walk's unresolved share; the
// unscattered parts are the same exact zeroth order in both.
inline void expect_totals_agree(const WalkAndSolver& both, int c, double z, const std::string& where) {
  const EnergyTotals& m = both.walk.totals;
  const AddingDoublingEstimate& ad = both.solver;
  const double unresolved = m.unresolved.value[c];
  auto near = [&](double a, double e, const Estimate& x, const char* what) {
    EXPECT_NEAR(a, x.value[c], z * x.stderr_[c] + e + unresolved)
        << where << " " << what << " stderr " << x.stderr_[c] << " estimate " << e;
  };
  near(ad.totals.R_diffuse[c], ad.error.R_diffuse[c], m.R_diffuse, "R_diffuse");
  near(ad.totals.T_diffuse[c], ad.error.T_diffuse[c], m.T_diffuse, "T_diffuse");
  near(ad.totals.absorbed[c], ad.error.absorbed[c], m.absorbed, "absorbed");
  EXPECT_NEAR(ad.totals.R_specular[c], m.R_specular.value[c], 1e-12) << where;
  EXPECT_NEAR(ad.totals.T_ballistic[c], m.T_ballistic.value[c], 1e-12) << where;
}

// Adding-doubling's bins against the walk's, one channel: each bin's z-score within 4.5 (Bonferroni
// over ~100 bins: P(|z| > 4.5) = 7e-6 each), and the chi-square of all of them consistent with
// their count (p > 1e-3, expect_consistent).
struct BinAgreement {
  double chi2 = 0.0;
  int dof = 0;
  void add(const BrdfTable& ad, const BrdfTable& mc, int bin, int channel, const std::string& where) {
    const double se = mc.stderr_[bin][channel];
    const double z = (ad.value[bin][channel] - mc.value[bin][channel]) / se;
    EXPECT_LT(std::abs(z), 4.5) << where << ": " << ad.value[bin][channel] << " vs " << mc.value[bin][channel] << " +- " << se;
    chi2 += z * z;
    ++dof;
  }
  void expect_consistent(const std::string& name) const {
    EXPECT_GT(chi_square_p_value(chi2, dof), 1e-3) << name << " chi2 " << chi2 << " / " << dof;
  }
};

}  // namespace lamina::test
