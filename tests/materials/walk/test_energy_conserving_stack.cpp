// Stacks with energy-conserving rough interfaces (LayerStack::interface_model EnergyConserving,
// materials/interfaces/microsurface.h) in the random walk (materials/walk/walk_kernel.h) and
// `lamina brdf` (materials/brdf/brdf_table.h):
//  * the white furnace: a rough stack over a white Lambert base with no absorption reflects 1,
//    at alpha 0.1 to 1 and incidence 0 to 75 degrees, with a rough top and a rough inner
//    interface; the single-scattering model fails the same test (it can fail);
//  * reciprocity of the BRDF's connection estimate through the sampled microsurface crossings;
//  * the smooth limit: alpha 0.01 against the smooth stack;
//  * a rough transmitting stack seen from both sides: its bihemispherical transmittance is the
//    same (reciprocity of T), its reflectance is not (the test can fail);
//  * the walk's exits straight through the rough top have the density that the connections' MIS
//    weights assume (exactly, walk by walk), and under a sky the MIS of connections and exits
//    reproduces the reflectance with less noise than the connections alone;
//  * the material file's keys, flipping and validation.
#include <cmath>
#include <string>

#include <gtest/gtest.h>
#include <glm/geometric.hpp>

#include "materials/brdf/brdf_table.h"
#include "materials/interfaces/fresnel.h"
#include "materials/interfaces/microsurface.h"
#include "materials/stack/stack_file.h"
#include "materials/walk/random_walk.h"
#include "materials/walk/walk_estimator.h"
#include "materials/base/sampling.h"
#include "tests/materials/walk/straight_exits.h"
#include "tests/support/statistics.h"

namespace lamina {
namespace {

using test::RunningStats;
using test::WithinKSigma;

glm::dvec3 from_angle(double theta_degrees, double phi = 0.0) {
  const double t = theta_degrees * kPi / 180.0;
  return {std::sin(t) * std::cos(phi), std::sin(t) * std::sin(phi), std::cos(t)};
}

// A non-absorbing scattering layer (two with a rough interface between them) over a white
// Lambert base: nothing can be absorbed, everything must come back out of the top.
LayerStack white_stack(double alpha, bool inner, InterfaceModel model = InterfaceModel::EnergyConserving) {
  LayerStack s;
  s.interface_model = model;
  s.top_roughness = alpha;
  s.layers.push_back(make_layer("a", 1.5, 0.3, Spectrum(0.0), Spectrum(6.0), Spectrum(0.7)));
  if (inner) {
    s.layers[0].bottom_roughness = alpha;
    s.layers.push_back(make_layer("b", 1.33, 0.4, Spectrum(0.0), Spectrum(3.0), Spectrum(0.0)));
  }
  s.below.kind = Below::Kind::Lambert;
  s.below.albedo = Spectrum(1.0);
  EXPECT_EQ(validate_stack(s), "");
  return s;
}

// The reflectance of the stack (everything that leaves the top, the glossy lobe included) by
// `lamina brdf`'s walks: one walk per photon, weight 1 out of a white stack but for the roulette.
RunningStats reflectance(const LayerStack& stack, const glm::dvec3& wi, int walks, std::uint64_t seed) {
  WalkPlan plan;
  prepare_walk(stack, {}, &plan);
  RunningStats r;
  for (int k = 0; k < walks; ++k) {
    Rng rng(seed, k);
    const WalkResult w = random_walk(plan, wi, rng);
    r.add(w.side == WalkResult::Side::Top ? w.weight[0] : 0.0);
  }
  return r;
}

TEST(EnergyConservingStack, WhiteFurnaceReflectsEverything) {
  int seed = 0;
  for (bool inner : {false, true})
    for (double alpha : {0.1, 0.3, 0.6, 1.0})
      for (double theta : {0.0, 45.0, 75.0}) {
        const RunningStats r = reflectance(white_stack(alpha, inner), from_angle(theta), 4000, 100 + seed++);
        EXPECT_NEAR(r.mean(), 1.0, 3.0 * r.standard_error() + 1e-12)
            << "alpha " << alpha << " theta " << theta << " inner " << inner << " se " << r.standard_error();
      }
}

TEST(EnergyConservingStack, TheSingleScatteringTopFailsTheFurnace) {
  // The same furnace with the single-scattering top (its glossy lobe added from its sampler, as
  // lamina brdf does): far below 1, the loss this model is for.
  const LayerStack stack = white_stack(0.6, false, InterfaceModel::SingleScattering);
  const RoughDielectric top{{0.6}, 1.0, 1.5};
  const glm::dvec3 wi = from_angle(45.0);
  const RunningStats walks = reflectance(stack, wi, 4000, 7);
  RunningStats glossy;
  Rng rng(8, 0);
  for (int k = 0; k < 100000; ++k) {
    glm::dvec3 r;
    double w = 0.0;
    glossy.add(top.sample_reflection(wi, {rng.uniform(), rng.uniform()}, &r, &w) ? w : 0.0);
  }
  const double se = std::hypot(walks.standard_error(), glossy.standard_error());
  EXPECT_LT(walks.mean() + glossy.mean(), 1.0 - 10.0 * se);
}

// f(a -> b) of the stack's walk by its events' connections (prepare_exit crossing the rough
// interfaces with an rng), per unit incident irradiance, times |b.z|... in the BRDF's own units.
RunningStats connection_brdf(const LayerStack& stack, const glm::dvec3& a, const glm::dvec3& b, int walks,
                             std::uint64_t seed) {
  RunningStats f;
  ExitDirection exit;
  for (int k = 0; k < walks; ++k) {
    Rng rng(seed, k);
    prepare_exit(stack, b, &exit, 0.0, {0.5, 0.5}, &rng);
    double sum = 0.0;
    random_walk(stack, a, rng, [&](const ScatterEvent& e) { sum += (e.throughput * connect_direct(stack, e, exit).weight)[0]; });
    f.add(sum);
  }
  return f;
}

TEST(EnergyConservingStack, BrdfIsReciprocal) {
  // One layer over a Lambert base: every path's first and last flights are straight (no interface
  // between the top and an event), so the connections estimate the whole non-glossy BRDF and
  // must be reciprocal. Absorbing, so that the paths of many orders are weighted unevenly.
  LayerStack s;
  s.interface_model = InterfaceModel::EnergyConserving;
  s.top_roughness = 0.5;
  s.layers.push_back(make_layer("a", 1.4, 0.5, Spectrum(0.3), Spectrum(8.0), Spectrum(0.6)));
  s.below.kind = Below::Kind::Lambert;
  s.below.albedo = Spectrum(0.6);
  ASSERT_EQ(validate_stack(s), "");
  const glm::dvec3 a = from_angle(20.0), b = from_angle(65.0, 2.0);
  const RunningStats ab = connection_brdf(s, a, b, 100000, 31), ba = connection_brdf(s, b, a, 100000, 32);
  const double se = std::hypot(ab.standard_error(), ba.standard_error());
  EXPECT_NEAR(ab.mean(), ba.mean(), 4.0 * se);
  EXPECT_GT(ab.mean(), 30.0 * se);
}

TEST(EnergyConservingStack, SmallAlphaIsTheSmoothStack) {
  // lamina brdf's totals at alpha 0.01 against the smooth stack's (its specular part exact).
  LayerStack smooth;
  smooth.layers.push_back(make_layer("a", 1.4, 0.3, Spectrum(0.5), Spectrum(5.0), Spectrum(0.5)));
  smooth.layers.push_back(make_layer("b", 1.5, 0.2, Spectrum(0.1), Spectrum(2.0), Spectrum(0.0)));
  smooth.below.ior = 1.0;
  LayerStack rough = smooth;
  rough.interface_model = InterfaceModel::EnergyConserving;
  rough.top_roughness = 0.01;
  rough.layers[0].bottom_roughness = 0.01;
  rough.layers[1].bottom_roughness = 0.01;
  ASSERT_EQ(validate_stack(rough), "");
  BrdfOptions options;
  options.theta_i_deg = 40.0;
  options.samples = 100000;
  options.bins_theta = 4;
  options.bins_phi = 4;
  const BrdfTable a = brdf_table_monte_carlo(smooth, options), b = brdf_table_monte_carlo(rough, options);
  auto near = [](const Estimate& x, const Estimate& y, const char* what) {
    const double se = std::hypot(x.stderr_[0], y.stderr_[0]);
    EXPECT_NEAR(x.value[0], y.value[0], 4.0 * se + 2e-3) << what;
  };
  near(a.totals.R_specular, b.totals.R_specular, "R_specular");
  near(a.totals.R_diffuse, b.totals.R_diffuse, "R_diffuse");
  near(a.totals.T_ballistic, b.totals.T_ballistic, "T_ballistic");
  near(a.totals.T_diffuse, b.totals.T_diffuse, "T_diffuse");
  EXPECT_GT(b.totals.R_specular.stderr_[0], 0.0) << "the rough stack's specular part is the walks'";
}

// The bihemispherical transmittance (or reflectance) of a stack from above: walks with
// cosine-weighted incidence, their bottom (top) exits, glossy and unscattered parts included.
RunningStats bihemispherical(const LayerStack& stack, bool transmitted, int walks, std::uint64_t seed) {
  WalkPlan plan;
  prepare_walk(stack, {}, &plan);
  RunningStats out;
  for (int k = 0; k < walks; ++k) {
    Rng rng(seed, k);
    const glm::dvec3 wi = sample_cosine_hemisphere({rng.uniform(), rng.uniform()});
    const WalkResult w = random_walk(plan, wi, rng);
    const auto side = transmitted ? WalkResult::Side::Bottom : WalkResult::Side::Top;
    out.add(w.side == side ? w.weight[0] : 0.0);
  }
  return out;
}

// A leaf-like stack: a thin forward-scattering cuticle with a rough top, a rough interface to an
// absorbing mesophyll, and a rough bottom; air on both sides.
LayerStack rough_leaf(double top, double inner, double bottom, double cuticle_sigma_a) {
  LayerStack s;
  s.interface_model = InterfaceModel::EnergyConserving;
  s.top_roughness = top;
  s.layers.push_back(make_layer("cuticle", 1.55, 0.03, Spectrum(cuticle_sigma_a), Spectrum(20.0), Spectrum(0.85)));
  s.layers[0].bottom_roughness = inner;
  s.layers.push_back(make_layer("mesophyll", 1.4, 0.25, Spectrum(1.5), Spectrum(12.0), Spectrum(0.3)));
  s.layers[1].bottom_roughness = bottom;
  s.below.ior = 1.0;
  EXPECT_EQ(validate_stack(s), "");
  return s;
}

TEST(EnergyConservingStack, TransmittingStackTransmitsAlikeFromBothSides) {
  // By reciprocity (air on both sides) the transmittance is the same seen from either side; the
  // reflectance differs.
  const LayerStack s = rough_leaf(0.3, 0.5, 0.8, 0.0);
  const LayerStack back = flipped(s);
  ASSERT_EQ(back.top_roughness, 0.8);
  ASSERT_EQ(back.layers[0].bottom_roughness, 0.5);
  ASSERT_EQ(back.layers[1].bottom_roughness, 0.3);
  const RunningStats t_front = bihemispherical(s, true, 100000, 41), t_back = bihemispherical(back, true, 100000, 42);
  const double se = std::hypot(t_front.standard_error(), t_back.standard_error());
  EXPECT_NEAR(t_front.mean(), t_back.mean(), 4.0 * se);
  EXPECT_GT(t_front.mean(), 0.1);
  const RunningStats r_front = bihemispherical(s, false, 100000, 43), r_back = bihemispherical(back, false, 100000, 44);
  EXPECT_GT(std::abs(r_front.mean() - r_back.mean()), 10.0 * std::hypot(r_front.standard_error(), r_back.standard_error()))
      << "the two sides must differ where reciprocity does not tie them";
}

TEST(EnergyConservingStack, ConnectionsMatchTheStraightExitsThroughEveryRoughInterface) {
  // The connections cross the rough interfaces by sampled microsurface walks (prepare_exit with an
  // rng); the walk's own exits straight from their last event are the same light: the reflectance
  // and the transmittance of those paths, two independent ways (connections towards a
  // cosine-sampled direction w weighted |w.z| / p(w), against the exits' weights).
  const LayerStack s = rough_leaf(0.4, 0.6, 0.25, 0.2);
  for (double side : {1.0, -1.0}) test::expect_connections_match_straight_exits(s, from_angle(35.0), side, 51 + (side > 0.0 ? 0 : 1));
}

// A grey absorbing skin-like stack under a rough top, with a smooth inner interface.
LayerStack rough_skin_like(double alpha) {
  LayerStack s;
  s.interface_model = InterfaceModel::EnergyConserving;
  s.top_roughness = alpha;
  s.layers.push_back(make_layer("oil", 1.5, 0.05, Spectrum(0.0), Spectrum(0.0), Spectrum(0.0)));
  s.layers.push_back(make_layer("skin", 1.4, 1.0, Spectrum(0.3), Spectrum(10.0), Spectrum(0.8)));
  s.below.kind = Below::Kind::Lambert;
  s.below.albedo = Spectrum(0.5);
  EXPECT_EQ(validate_stack(s), "");
  return s;
}

double power_heuristic(double a, double b) { return a * a + b * b > 0.0 ? a * a / (a * a + b * b) : 0.0; }

TEST(EnergyConservingStack, StraightExitsThroughTheTopHaveTheConnectionsDensity) {
  // A grey walk that leaves straight from its last event through the top's microsurface (weight
  // 1) has the density exit_pdf of prepare_exit_through from its inside direction; then
  // W_exit exit_pdf / |w.z| equals the event's connection weight through that direction, to
  // rounding: the density ratio (n_out / n_layer)^2 |w.z| / mu that reciprocity gives, the Fresnel
  // terms and the attenuations must be the connections'.
  int checked = 0;
  for (double alpha : {0.05, 0.3, 0.9}) {
    const LayerStack stack = rough_skin_like(alpha);
    for (double theta : {0.0, 45.0, 80.0}) {
      SCOPED_TRACE(testing::Message() << "alpha " << alpha << ", theta " << theta);
      checked += test::check_straight_top_exits(stack, from_angle(theta, 1.0), 3000, 61);
    }
  }
  EXPECT_GT(checked, 2000);
}

TEST(EnergyConservingStack, MisOfConnectionsAndExitsUnderASky) {
  // Light of unit radiance from the whole upper hemisphere, sampled by the cosine: the stack's
  // reflectance three ways. Its exits alone; the connections (through sampled microsurface
  // crossings) combined by the power heuristic with the straight exits through the top; and the
  // connections alone standing for those exits (what they did before the exits had a density).
  // A wrong density on either side biases the combination; the combination must also be the less
  // noisy of the two connection estimators (the exits find the bright directions of the sky that
  // one light sample per walk misses).
  const LayerStack stack = rough_skin_like(0.3);
  const glm::dvec3 wi = from_angle(25.0);
  WalkOptions settings;
  settings.compute_exit_pdf = true;
  RunningStats exits_only, combined, connections_only;
  Rng rng(62, 0);
  ExitDirection exit;
  for (int k = 0; k < 100000; ++k) {
    const glm::dvec3 wl = sample_cosine_hemisphere({rng.uniform(), rng.uniform()});
    const double p_light = wl.z * kInvPi;
    prepare_exit(stack, wl, &exit, 0.0, {0.5, 0.5}, &rng);
    double mis_sum = 0.0, plain_sum = 0.0;
    const WalkResult r = random_walk(stack, wi, rng, [&](const ScatterEvent& e) {
      const DirectExit d = connect_direct(stack, e, exit);
      const double c = (e.throughput * d.weight)[0] * wl.z / p_light;
      mis_sum += c * power_heuristic(p_light, d.pdf_for_mis);
      plain_sum += c;
    }, settings);
    const double exit_weight = r.side == WalkResult::Side::Top ? r.weight[0] : 0.0;
    exits_only.add(exit_weight);
    if (exit_weight > 0.0) {
      if (r.straight_from_last_event) {
        mis_sum += exit_weight * power_heuristic(r.exit_pdf, r.direction.z * kInvPi);
      } else {
        mis_sum += exit_weight;  // the glossy reflection at entry, or after an internal reflection
        plain_sum += exit_weight;
      }
    }
    combined.add(mis_sum);
    connections_only.add(plain_sum);
  }
  const double se = std::hypot(exits_only.standard_error(), combined.standard_error());
  EXPECT_TRUE(WithinKSigma(combined.mean(), exits_only.mean(), se));
  EXPECT_TRUE(WithinKSigma(connections_only.mean(), exits_only.mean(),
                           std::hypot(exits_only.standard_error(), connections_only.standard_error())));
  EXPECT_LT(combined.standard_error(), 0.7 * connections_only.standard_error());
}

TEST(EnergyConservingStack, MaterialFileKeys) {
  const std::string layers =
      R"("layers": [{"ior": 1.5, "thickness": 0.1, "bottom_roughness": 0.4, "sigma_a": 0.1, "sigma_s": 1, "g": 0},
                    {"ior": 1.3, "thickness": 0.2, "sigma_a": 0.1, "sigma_s": 1, "g": 0}], "below": {"ior": 1.0})";
  const LayerStack s = parse_stack_json(
      R"({"lamina_material": 1, "roughness": 0.2, "interface_model": "energy_conserving", )" + layers + "}", "m.json");
  EXPECT_EQ(s.interface_model, InterfaceModel::EnergyConserving);
  EXPECT_EQ(s.top_roughness, 0.2);
  EXPECT_EQ(s.layers[0].bottom_roughness, 0.4);
  EXPECT_EQ(s.energy_conserving_alpha(1), 0.4);
  EXPECT_EQ(s.energy_conserving_alpha(2), 0.0);
  // Without the key a file means the energy-conserving model, as the struct's default does (one
  // declaration): rough inner interfaces and transmitting stacks are accepted.
  EXPECT_EQ(parse_stack_json(R"({"lamina_material": 1, "roughness": 0.2, "layers": [{"ior": 1.5, "thickness": "inf",
            "sigma_a": 0.1, "sigma_s": 1, "g": 0}]})", "m.json").interface_model, InterfaceModel::EnergyConserving);
  EXPECT_EQ(LayerStack().interface_model, InterfaceModel::EnergyConserving);
  const LayerStack by_default = parse_stack_json(R"({"lamina_material": 1, "roughness": 0.2, )" + layers + "}", "m.json");
  EXPECT_EQ(by_default.energy_conserving_alpha(0), 0.2);
  EXPECT_EQ(by_default.energy_conserving_alpha(1), 0.4);
  // The single-scattering top is explicit; it refuses rough inner interfaces and transmitting stacks.
  EXPECT_EQ(parse_stack_json(R"({"lamina_material": 1, "roughness": 0.2, "interface_model": "single_scattering",
            "layers": [{"ior": 1.5, "thickness": "inf", "sigma_a": 0.1, "sigma_s": 1, "g": 0}]})", "m.json").interface_model,
            InterfaceModel::SingleScattering);
  auto error_of = [](const std::string& text) {
    try {
      parse_stack_json(text, "m.json");
    } catch (const StackFileError& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_NE(error_of(R"({"lamina_material": 1, "interface_model": "single_scattering", )" + layers + "}")
                .find("layers[0].bottom_roughness: rough inner"),
            std::string::npos);
  EXPECT_NE(error_of(R"({"lamina_material": 1, "roughness": 0.2, "interface_model": "single_scattering", "layers": [
            {"ior": 1.5, "thickness": 0.1, "sigma_a": 0.1, "sigma_s": 1, "g": 0}], "below": {"ior": 1.0}})")
                .find("by the single-scattering model"),
            std::string::npos);
  EXPECT_NE(error_of(R"({"lamina_material": 1, "interface_model": "multiple", )" + layers + "}").find("interface_model: expected"),
            std::string::npos);
  EXPECT_NE(error_of(R"({"lamina_material": 1, "interface_model": "energy_conserving", "layers": [{"ior": 1.5,
            "thickness": 1, "bottom_roughness": 0.3, "sigma_a": 0.1, "sigma_s": 1, "g": 0}], "below": {"lambert": 0.5}})")
                .find("layers[0].bottom_roughness: the last layer has no bottom interface"),
            std::string::npos);
  EXPECT_NE(error_of(R"({"lamina_material": 1, "interface_model": "energy_conserving", "layers": [{"ior": 1.5,
            "thickness": 1, "bottom_roughness": 1.5, "sigma_a": 0.1, "sigma_s": 1, "g": 0}], "below": {"ior": 1}})")
                .find("layers[0].bottom_roughness: must be a number in [0, 1]"),
            std::string::npos);
}

}  // namespace
}  // namespace lamina
