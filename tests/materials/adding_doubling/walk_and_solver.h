// The walk's totals and adding-doubling's at one incidence, for the tests that hold one against
// the other (test_adding_doubling, test_rough_adding_doubling).
#pragma once

#include <cmath>
#include <cstdint>

#include "materials/adding_doubling/adding_doubling.h"
#include "materials/brdf/brdf_table.h"

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

}  // namespace lamina::test
