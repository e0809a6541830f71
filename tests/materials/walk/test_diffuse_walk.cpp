// Diffuse interfaces (materials/interfaces/diffuse_interface.h) in the random walk
// (materials/walk/walk_kernel.h), `lamina brdf --method monte-carlo` (materials/brdf/brdf_table.h)
// and the connections (prepare_exit): against adding-doubling, which builds the same interface
// on its nodes (adding_doubling.cpp, 13.), and against themselves.
//  * R and T of the walk against adding-doubling's within 3 standard errors plus the solver's
//    discretisation estimate, on scattering stacks with a diffuse top, an inner diffuse interface
//    and a diffuse bottom, lit from air, from a denser medium (the top then reflects diffusely)
//    and from below; and per bin (each within 4.5 standard errors, chi-square consistent);
//  * the connections through diffuse interfaces against the walk's straight exits, up and down;
//  * reciprocity of the BRDF's connection estimate under a diffuse top;
//  * determinism per seed.
#include <cmath>
#include <string>

#include <gtest/gtest.h>

#include "materials/adding_doubling/adding_doubling.h"
#include "materials/base/sampling.h"
#include "materials/brdf/brdf_table.h"
#include "materials/interfaces/fresnel.h"
#include "materials/walk/random_walk.h"
#include "tests/materials/adding_doubling/walk_and_solver.h"
#include "tests/materials/stack_fixtures.h"
#include "tests/materials/walk/straight_exits.h"
#include "tests/support/statistics.h"

namespace lamina {
namespace {

using test::RunningStats;

glm::dvec3 from_angle(double theta_degrees, double phi = 0.0) {
  const double t = theta_degrees * kPi / 180.0;
  return {std::sin(t) * std::cos(phi), std::sin(t) * std::sin(phi), std::cos(t)};
}

// Two grey absorbing, scattering layers with an index step between them; diffuse top, inner and
// bottom interfaces; `above` the index of the medium above.
LayerStack diffuse_leaf(double above = 1.0) {
  LayerStack s = test::stack_of({make_layer("cuticle", 1.5, 0.05, Spectrum(0.4), Spectrum(6.0), Spectrum(0.5)),
                                 make_layer("cells", 1.35, 0.3, Spectrum(0.8), Spectrum(12.0), Spectrum(0.8))},
                                above, 1.0);
  s.top_diffuse = true;
  s.layers[0].bottom_diffuse = true;
  s.layers[1].bottom_diffuse = true;
  s.name = "diffuse leaf above " + std::to_string(above);
  EXPECT_EQ(validate_stack(s), "");
  return s;
}

// The walk's reflectance (the top's specular reflection included: exact where the walk leaves it
// to the caller) and transmittance, photon by photon.
struct WalkRT {
  RunningStats r, t;
};
WalkRT walk_totals(const LayerStack& s, const glm::dvec3& wi, int walks, std::uint64_t seed) {
  WalkPlan plan;
  prepare_walk(s, {}, &plan);
  // From the light side the walk carries 1 - F and the specular F is the caller's.
  const double specular = s.above_ior < s.layers[0].ior ? fresnel_dielectric(wi.z, s.above_ior, s.layers[0].ior) : 0.0;
  WalkRT out;
  for (int k = 0; k < walks; ++k) {
    Rng rng(seed, k);
    const WalkResult w = random_walk(plan, wi, rng);
    out.r.add(specular + (w.side == WalkResult::Side::Top ? w.weight[0] : 0.0));
    out.t.add(w.side == WalkResult::Side::Bottom ? w.weight[0] : 0.0);
  }
  return out;
}

// R and T within 3 standard errors of the walk plus the solver's discretisation estimate (order
// 16 against 8) and the walk's unresolved share (0 here: no walk reaches the forced tail).
void expect_walk_matches_solver(const LayerStack& s, double theta_deg) {
  const glm::dvec3 wi = from_angle(theta_deg);
  const WalkRT walk = walk_totals(s, wi, 100000, 17);
  const AddingDoublingEstimate ad = adding_doubling_with_error(s, wi.z);
  const double r = ad.totals.R_specular[0] + ad.totals.R_diffuse[0], t = ad.totals.T_ballistic[0] + ad.totals.T_diffuse[0];
  const double er = ad.error.R_specular[0] + ad.error.R_diffuse[0], et = ad.error.T_ballistic[0] + ad.error.T_diffuse[0];
  EXPECT_NEAR(walk.r.mean(), r, 3.0 * walk.r.standard_error() + er)
      << s.name << " theta " << theta_deg << " stderr " << walk.r.standard_error() << " solver error " << er;
  EXPECT_NEAR(walk.t.mean(), t, 3.0 * walk.t.standard_error() + et)
      << s.name << " theta " << theta_deg << " stderr " << walk.t.standard_error() << " solver error " << et;
  EXPECT_GT(t, 0.05);
}

TEST(DiffuseWalk, TotalsMatchAddingDoubling) {
  for (double theta : {0.0, 45.0, 75.0}) {
    expect_walk_matches_solver(diffuse_leaf(1.0), theta);
    expect_walk_matches_solver(diffuse_leaf(1.7), theta);  // the top met from its dense side
    LayerStack back = flipped(diffuse_leaf(1.0));
    back.name = "diffuse leaf from below";
    expect_walk_matches_solver(back, theta);
  }
}

// `lamina brdf`'s split: the unscattered light (R_specular, T_ballistic: spread by the diffuse
// interfaces, from the walks) and the scattered light against the solver's, within 4.3
// standard errors (five parts at once) plus the solver's estimate.
TEST(DiffuseWalk, BrdfTotalsSplitAsTheSolver) {
  const LayerStack s = diffuse_leaf(1.0);
  const test::WalkAndSolver both = test::walk_and_solver(s, 30.0, 100000);
  const EnergyTotals& m = both.walk.totals;
  const AddingDoublingEstimate& ad = both.solver;
  auto near = [&](double a, double e, const Estimate& x, const char* what) {
    EXPECT_NEAR(a, x.value[0], 4.3 * x.stderr_[0] + e) << what << " stderr " << x.stderr_[0] << " solver error " << e;
  };
  near(ad.totals.R_specular[0], ad.error.R_specular[0], m.R_specular, "R_specular");
  near(ad.totals.R_diffuse[0], ad.error.R_diffuse[0], m.R_diffuse, "R_diffuse");
  near(ad.totals.T_ballistic[0], ad.error.T_ballistic[0], m.T_ballistic, "T_ballistic");
  near(ad.totals.T_diffuse[0], ad.error.T_diffuse[0], m.T_diffuse, "T_diffuse");
  near(ad.totals.absorbed[0], ad.error.absorbed[0], m.absorbed, "absorbed");
  EXPECT_GT(ad.totals.T_ballistic[0], 1e-3);  // light that crossed without scattering, spread (0.0016)
}

// Per bin: the walk's exits after at least one scattering against the solver's bins of the
// same light, reflection and transmission, from air and from below.
TEST(DiffuseWalk, BinsMatchAddingDoubling) {
  for (bool from_below : {false, true}) {
    LayerStack s = from_below ? flipped(diffuse_leaf(1.0)) : diffuse_leaf(1.0);
    BrdfOptions o;
    o.theta_i_deg = 40.0;
    o.samples = 200000;
    o.bins_theta = 3;
    o.bins_phi = 4;
    const BrdfTable ad = brdf_table_adding_doubling(s, o);
    const BrdfTable mc = brdf_table_monte_carlo(s, o);
    test::BinAgreement agreement;
    for (int side = 0; side < 2; ++side)
      for (int k = 0; k < o.bins_theta; ++k)
        for (int m = 0; m < o.bins_phi; ++m) {
          const int b = ad.bin_index(static_cast<BrdfSide>(side), k, m);
          ASSERT_GT(mc.stderr_[b][0], 0.0);
          agreement.add(ad, mc, b, 0, s.name + (from_below ? " below" : "") + " side " + std::to_string(side) +
                                          " k " + std::to_string(k) + " m " + std::to_string(m));
        }
    agreement.expect_consistent(s.name);
  }
}

TEST(DiffuseWalk, ConnectionsMatchTheStraightExits) {
  // The connections cross diffuse interfaces by a cosine-sampled inside direction (prepare_exit
  // with an rng); the walk's exits straight from their last event are the same light: the
  // reflectance and the transmittance of those paths two independent ways (connections towards
  // a cosine-sampled w weighted |w.z| / p(w), against the exits' weights), within 4 standard
  // errors.
  const LayerStack s = diffuse_leaf(1.0);
  for (double side : {1.0, -1.0})
    test::expect_connections_match_straight_exits(s, from_angle(35.0), side, 61 + (side > 0.0 ? 0 : 1), [](const WalkResult& r) {
      // Every straight exit crossed a diffuse interface: no closed-form density (connections alone).
      EXPECT_TRUE(r.crossed_rough);
    });
}

TEST(DiffuseWalk, ConnectionBrdfIsReciprocal) {
  // One absorbing layer under a diffuse top over a Lambert base: every path that scattered leaves
  // straight from its last event (an internal reflection at the top is followed by the substrate
  // or a collision), so the connections estimate the whole BRDF but the top's specular part, and
  // must be reciprocal.
  LayerStack s;
  s.top_diffuse = true;
  s.layers.push_back(make_layer("a", 1.4, 0.5, Spectrum(0.3), Spectrum(8.0), Spectrum(0.6)));
  s.below.kind = Below::Kind::Lambert;
  s.below.albedo = Spectrum(0.6);
  ASSERT_EQ(validate_stack(s), "");
  auto brdf = [&](const glm::dvec3& a, const glm::dvec3& b, std::uint64_t seed) {
    RunningStats f;
    ExitDirection exit;
    for (int k = 0; k < 100000; ++k) {
      Rng rng(seed, k);
      prepare_exit(s, b, &exit, 0.0, {0.5, 0.5}, &rng);
      double sum = 0.0;
      random_walk(s, a, rng, [&](const ScatterEvent& e) { sum += (e.throughput * connect_direct(s, e, exit).weight)[0]; });
      f.add(sum);
    }
    return f;
  };
  const glm::dvec3 a = from_angle(20.0), b = from_angle(65.0, 2.0);
  const RunningStats ab = brdf(a, b, 71), ba = brdf(b, a, 72);
  const double se = std::hypot(ab.standard_error(), ba.standard_error());
  EXPECT_NEAR(ab.mean(), ba.mean(), 4.0 * se);
  EXPECT_GT(ab.mean(), 30.0 * se);
}

TEST(DiffuseWalk, SameSeedSameWalk) {
  const LayerStack s = diffuse_leaf(1.7);
  for (int k = 0; k < 200; ++k) {
    Rng a(5, k), b(5, k);
    const WalkResult x = random_walk(s, from_angle(30.0), a), y = random_walk(s, from_angle(30.0), b);
    EXPECT_EQ(x.weight, y.weight);
    EXPECT_EQ(x.direction, y.direction);
  }
}

}  // namespace
}  // namespace lamina
