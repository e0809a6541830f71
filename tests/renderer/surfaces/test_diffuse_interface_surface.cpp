// Diffusely transmitting outer interfaces in the random-walk surface (random_walk_surface.cpp,
// scatter_through_diffuse; docs/layered_rendering.md, "Diffusely transmitting interfaces").
//  * Closed forms (tests/renderer/surfaces/diffuse_plate.h): a plate that absorbs and does not
//    scatter, with a diffuse top, a diffuse top and bottom, or a smooth top over a diffuse bottom.
//    The surface's estimates under a sky (light samples and continuations by MIS) and towards
//    delta lights (connections alone) must match them within 3 standard errors.
//  * A scattering slab: under a sky cap the light connections with MIS must give what the
//    continuations alone give (no connection at all): two estimators of one integral.
#include <cmath>
#include <functional>
#include <vector>

#include <gtest/gtest.h>
#include <glm/geometric.hpp>

#include "materials/interfaces/fresnel.h"
#include "materials/walk/random_walk.h"
#include "renderer/surfaces/random_walk_surface.h"
#include "tests/renderer/surfaces/diffuse_plate.h"
#include "tests/renderer/surfaces/sky_furnace.h"
#include "tests/support/statistics.h"

namespace lamina {
namespace {

using test::RunningStats;
using test::WithinKSigma;

using test::Plate;
using test::PlateOptics;
using test::kN;
using test::plate_optics;
using test::plate_stack;

// The walk surface with the hero channel stratified over the calls (0, 1, 2, 0, ...), as the
// renderer chooses it (renderer/layered/hero_strata.h): uniform marginally, the same for the
// walks of one call.
class StratifiedHeroSurface final : public Surface {
 public:
  explicit StratifiedHeroSurface(const LayerStack& stack)
      : walks_{{stack, 0, RandomWalkOptions{}}, {stack, 1, RandomWalkOptions{}}, {stack, 2, RandomWalkOptions{}}} {}
  bool scatter(const glm::dvec3& wo, Rng& rng, LightDirection* lights, int light_count, LightSampler* per_event,
               SurfaceScatter* next) const override {
    return walks_[calls_++ % 3].scatter(wo, rng, lights, light_count, per_event, next);
  }

 private:
  RandomWalkSurface walks_[3];
  mutable int calls_ = 0;
};

glm::dvec3 from_angle(double theta_degrees, double phi = 0.0) {
  const double t = theta_degrees * kPi / 180.0;
  return {std::sin(t) * std::cos(phi), std::sin(t) * std::sin(phi), std::cos(t)};
}

struct PlateCase {
  Plate plate;
  double theta;
};

class DiffusePlate : public testing::TestWithParam<PlateCase> {};

INSTANTIATE_TEST_SUITE_P(RandomWalkSurfaceDiffuse, DiffusePlate,
                         testing::Values(PlateCase{{true, false}, 20.0}, PlateCase{{true, false}, 70.0},
                                         PlateCase{{true, true}, 40.0}, PlateCase{{false, true}, 30.0}));

TEST_P(DiffusePlate, SkyAboveAndBelowGiveTheClosedForms) {
  const PlateCase pc = GetParam();
  const LayerStack stack = plate_stack(pc.plate);
  const glm::dvec3 wo = from_angle(pc.theta);
  const StratifiedHeroSurface surface(stack);
  RunningStats above[3], below[3];
  test::sky_furnace(surface, wo, 41, 100000, above);
  test::sky_furnace(surface, wo, 42, 100000, below, -1.0);
  for (int c = 0; c < 3; ++c) {
    const PlateOptics o = plate_optics(pc.plate, wo, c);
    EXPECT_TRUE(WithinKSigma(above[c].mean(), o.specular + o.reflected, above[c].standard_error(), 3.0))
        << "reflectance, channel " << c << ": " << above[c].mean() << " against " << o.specular + o.reflected;
    EXPECT_TRUE(WithinKSigma(below[c].mean(), o.transmitted, below[c].standard_error(), 3.0))
        << "transmittance, channel " << c << ": " << below[c].mean() << " against " << o.transmitted;
    EXPECT_GT(o.transmitted, 20.0 * below[c].standard_error()) << "channel " << c;
  }
}

TEST_P(DiffusePlate, DeltaLightsAboveAndBelowGiveTheClosedForms) {
  const PlateCase pc = GetParam();
  const LayerStack stack = plate_stack(pc.plate);
  const glm::dvec3 wo = from_angle(pc.theta);
  const StratifiedHeroSurface surface(stack);
  const glm::dvec3 lights_at[2] = {from_angle(35.0, 2.0), from_angle(150.0, 1.0)};
  for (const glm::dvec3& wl : lights_at) {
    RunningStats est[3];
    for (int k = 0; k < 100000; ++k) {
      Rng rng(43, k);
      LightDirection light;
      light.wi = wl;
      light.delta = true;
      SurfaceScatter next;
      surface.scatter(wo, rng, &light, 1, nullptr, &next);
      for (int c = 0; c < 3; ++c) est[c].add(light.f_cos[c]);
    }
    for (int c = 0; c < 3; ++c) {
      const double expected = plate_optics(pc.plate, wo, c).f_cos(wl);
      // 4 standard errors: 24 comparisons share this test (tests/renderer/layered/test_layered.cpp's
      // convention).
      EXPECT_TRUE(WithinKSigma(est[c].mean(), expected, est[c].standard_error(), 4.0, 1e-12))
          << "light at z " << wl.z << ", channel " << c << ": " << est[c].mean() << " against " << expected;
      if (expected > 0.0) {
        EXPECT_GT(expected, 20.0 * est[c].standard_error()) << "channel " << c;
      }
    }
  }
}

// A sky of radiance 1 in the cap |cos theta| > cos(45 degrees) on one side (side +1 above, -1
// below), black elsewhere: with the light sampled by the cosine over the whole hemisphere and MIS
// against the continuation (connections), or by the continuation alone (no light sample).
void cap_furnace(const RandomWalkSurface& surface, const glm::dvec3& wo, std::uint64_t seed, int calls, double side,
                 bool connections, RunningStats* est) {
  const double cap = std::cos(kPi / 4.0);
  for (int k = 0; k < calls; ++k) {
    Rng rng(seed, k);
    LightDirection light;
    light.wi = sample_cosine_hemisphere({rng.uniform(), rng.uniform()});
    light.pdf = light.wi.z * kInvPi;
    const bool light_in_cap = light.wi.z > cap;
    light.wi.z *= side;
    SurfaceScatter next;
    Spectrum x(0.0);
    const bool continues = surface.scatter(wo, rng, &light, connections ? 1 : 0, nullptr, &next);
    if (continues && next.wi.z * side > cap) {
      double mis = 1.0;
      if (connections) mis = next.delta ? 1.0 : power_heuristic(next.pdf, std::abs(next.wi.z) * kInvPi);
      x = next.weight * mis;
    }
    if (connections && light_in_cap) x += light.f_cos / light.pdf;
    for (int c = 0; c < 3; ++c) est[c].add(x[c]);
  }
}

TEST(RandomWalkSurfaceDiffuse, ScatteringSlabConnectionsAgreeWithContinuationsAlone) {
  for (const bool bottom : {false, true}) {
    LayerStack s;
    s.layers.push_back(make_layer("cuticle", 1.5, 0.02, Spectrum(0.2), Spectrum(5.0), Spectrum(0.0)));
    s.layers.push_back(make_layer("mesophyll", 1.4, 0.2, Spectrum(0.3, 1.0, 3.0), Spectrum(20.0), Spectrum(0.6)));
    s.below.ior = 1.0;
    s.top_diffuse = true;
    s.layers[1].bottom_diffuse = bottom;
    const RandomWalkSurface surface(s, kRandomHero, RandomWalkOptions{});
    const glm::dvec3 wo = from_angle(50.0);
    for (const double side : {1.0, -1.0}) {
      RunningStats mis[3], alone[3];
      cap_furnace(surface, wo, 44, 100000, side, true, mis);
      cap_furnace(surface, wo, 45, 100000, side, false, alone);
      for (int c = 0; c < 3; ++c) {
        const double se = std::hypot(mis[c].standard_error(), alone[c].standard_error());
        EXPECT_TRUE(WithinKSigma(mis[c].mean(), alone[c].mean(), se, 3.0))
            << (bottom ? "diffuse bottom" : "smooth bottom") << ", side " << side << ", channel " << c << ": "
            << mis[c].mean() << " against " << alone[c].mean();
        EXPECT_GT(alone[c].mean(), 10.0 * se) << "channel " << c;
      }
    }
  }
}

}  // namespace
}  // namespace lamina
