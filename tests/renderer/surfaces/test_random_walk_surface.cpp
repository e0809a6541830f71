// The layered walk as a stochastic surface with a rough top (renderer/surfaces/random_walk_surface.h):
// one scatter() call's light connections and continuation, against independent estimates from
// materials/: the glossy lobe by quadrature of RoughDielectric::eval, the walk's part by
// materials' random_walk exits and connections.
//  * Under a uniform sky sampled by the cosine (one light sample per call, MIS against the
//    surface's continuation), E[connection / p + continuation x MIS] is the surface's albedo:
//    glossy albedo + the walk's top exits.
//  * Towards a delta light, E[f_cos] = (f_glossy + f_walk) cos, f_walk from materials'
//    connections through sampled facets.
//  * Roughness 0 is the smooth surface, call for call (the same random numbers, bit-identical).
#include <cmath>

#include <gtest/gtest.h>
#include <glm/geometric.hpp>

#include "materials/interfaces/microfacet.h"
#include "materials/interfaces/microsurface.h"
#include "materials/walk/random_walk.h"
#include "renderer/surfaces/random_walk_surface.h"
#include "tests/support/sphere_quadrature.h"
#include "tests/renderer/surfaces/sky_furnace.h"
#include "tests/support/statistics.h"

namespace lamina {
namespace {

using test::RunningStats;
using test::sky_furnace;
using test::WithinKSigma;

LayerStack rough_skin(double alpha) {
  LayerStack s;
  s.above_ior = 1.0;
  s.top_roughness = alpha;
  s.interface_model = InterfaceModel::SingleScattering;  // the single-scattering top's lobe and connections
  s.layers.push_back(make_layer("epidermis", 1.4, 0.3, Spectrum(0.2, 0.5, 0.9), Spectrum(12.0), Spectrum(0.7)));
  s.below.kind = Below::Kind::Lambert;
  s.below.albedo = Spectrum(0.7, 0.5, 0.4);
  EXPECT_EQ(validate_stack(s), "");
  return s;
}

glm::dvec3 from_angle(double theta_degrees) {
  const double t = theta_degrees * kPi / 180.0;
  return {std::sin(t), 0.0, std::cos(t)};
}

// integral over the upper hemisphere of f(wo, wi) cos(wi), by adaptive quadrature.
double glossy_albedo(const RoughDielectric& top, const glm::dvec3& wo) {
  return test::integrate_sphere([&](const glm::dvec3& wi) { return top.eval(wo, wi) * wi.z; }, true);
}


// materials' walks: the mean weight of their top exits (with the walk's own glossy reflection
// where it takes it), or of their bottom exits.
void walk_albedo(const LayerStack& stack, const glm::dvec3& wo, std::uint64_t seed, int walks, RunningStats* walk,
                 WalkResult::Side side = WalkResult::Side::Top) {
  for (int k = 0; k < walks; ++k) {
    Rng rng(seed, k);
    const WalkResult r = random_walk(stack, wo, rng);
    for (int c = 0; c < 3; ++c) walk[c].add(r.side == side ? r.weight[c] : 0.0);
  }
}

class SkyFurnace : public testing::TestWithParam<std::pair<double, double>> {};

// A broad lobe where the light samples carry most of it, and a narrow one at grazing view
// (Fresnel 0.3) where the surface's own sampling does.
INSTANTIATE_TEST_SUITE_P(RandomWalkSurfaceRough, SkyFurnace,
                         testing::Values(std::make_pair(0.3, 50.0), std::make_pair(0.08, 75.0)));

TEST_P(SkyFurnace, IsGlossyPlusWalkAlbedo) {
  const double alpha = GetParam().first;
  const LayerStack stack = rough_skin(alpha);
  const glm::dvec3 wo = from_angle(GetParam().second);
  RandomWalkOptions options;
  const RandomWalkSurface surface(stack, kRandomHero, options);
  RunningStats est[3], walk[3];
  sky_furnace(surface, wo, 31, 200000, est);
  walk_albedo(stack, wo, 32, 200000, walk);
  const double glossy = glossy_albedo(RoughDielectric{{alpha}, 1.0, 1.4}, wo);
  EXPECT_GT(glossy, 0.02);
  for (int c = 0; c < 3; ++c)
    EXPECT_TRUE(WithinKSigma(est[c].mean(), glossy + walk[c].mean(), std::hypot(est[c].standard_error(), walk[c].standard_error())))
        << "channel " << c;
}

TEST(RandomWalkSurfaceRough, DeltaLightConnectionIsGlossyPlusWalkBrdf) {
  const double alpha = 0.4;
  const LayerStack stack = rough_skin(alpha);
  const glm::dvec3 wo = from_angle(20.0), wl = glm::normalize(glm::dvec3(-0.5, 0.3, 0.8));
  const RandomWalkSurface surface(stack, kRandomHero, RandomWalkOptions{});
  RunningStats est[3], walk[3];
  for (int k = 0; k < 100000; ++k) {
    Rng rng(33, k);
    LightDirection light;
    light.wi = wl;
    light.delta = true;
    SurfaceScatter next;
    surface.scatter(wo, rng, &light, 1, nullptr, &next);
    for (int c = 0; c < 3; ++c) est[c].add(light.f_cos[c]);
  }
  ExitDirection exit;
  for (int k = 0; k < 100000; ++k) {
    Rng rng(34, k);
    prepare_exit(stack, wl, &exit, 0.0, {rng.uniform(), rng.uniform()});
    Spectrum sum(0.0);
    random_walk(stack, wo, rng, [&](const ScatterEvent& e) { sum += e.throughput * connect_direct(stack, e, exit).weight; });
    for (int c = 0; c < 3; ++c) walk[c].add(sum[c] * wl.z);
  }
  const double glossy = RoughDielectric{{alpha}, 1.0, 1.4}.eval(wo, wl) * wl.z;
  for (int c = 0; c < 3; ++c)
    EXPECT_TRUE(WithinKSigma(est[c].mean(), glossy + walk[c].mean(), std::hypot(est[c].standard_error(), walk[c].standard_error())))
        << "channel " << c;
}

// The energy-conserving rough interfaces (materials/interfaces/microsurface.h): light samples
// alone carry the glossy lobe and the exits through rough interfaces (their continuation counts 0
// on an emitter). Under the cosine-sampled sky, E[connection / p + continuation x MIS] must be the
// albedo that materials' walks give by their exits alone (glossy reflection included): two
// independent estimators. A white stack (no absorption, white base, a rough inner interface too)
// must give 1.
struct EnergyConservingCase {
  double alpha, theta;
  bool white;
};
class EnergyConservingSkyFurnace : public testing::TestWithParam<EnergyConservingCase> {};
INSTANTIATE_TEST_SUITE_P(RandomWalkSurfaceRough, EnergyConservingSkyFurnace,
                         testing::Values(EnergyConservingCase{0.3, 50.0, false}, EnergyConservingCase{0.08, 75.0, false},
                                         EnergyConservingCase{0.6, 30.0, true}));

TEST_P(EnergyConservingSkyFurnace, IsTheWalksAlbedo) {
  const EnergyConservingCase c = GetParam();
  LayerStack stack = rough_skin(c.alpha);
  stack.interface_model = InterfaceModel::EnergyConserving;
  if (c.white) {
    stack.layers[0] = make_layer("top", 1.5, 0.2, Spectrum(0.0), Spectrum(6.0), Spectrum(0.7));
    stack.layers[0].bottom_roughness = c.alpha;
    stack.layers.push_back(make_layer("bottom", 1.3, 0.3, Spectrum(0.0), Spectrum(4.0), Spectrum(0.0)));
    stack.below.albedo = Spectrum(1.0);
  }
  ASSERT_EQ(validate_stack(stack), "");
  const glm::dvec3 wo = from_angle(c.theta);
  const RandomWalkSurface surface(stack, kRandomHero, RandomWalkOptions{});
  RunningStats est[3], walk[3];
  sky_furnace(surface, wo, 35, 100000, est);
  walk_albedo(stack, wo, 36, 100000, walk);
  for (int ch = 0; ch < 3; ++ch) {
    const double se = std::hypot(est[ch].standard_error(), walk[ch].standard_error());
    EXPECT_TRUE(WithinKSigma(est[ch].mean(), walk[ch].mean(), se)) << "channel " << ch;
    if (c.white) {
      EXPECT_TRUE(WithinKSigma(est[ch].mean(), 1.0, est[ch].standard_error())) << "channel " << ch;
    }
  }
}

TEST(RandomWalkSurfaceRough, EnergyConservingLeafTransmitsItsWalksTransmittance) {
  // A rough leaf (air on both sides: no n^2 factor) under a sky below: the light samples through
  // its rough bottom and inner interfaces (sampled microsurface crossings) plus the continuations
  // that leave below must add up to the transmittance of materials' walks.
  LayerStack s;
  s.interface_model = InterfaceModel::EnergyConserving;
  s.top_roughness = 0.3;
  s.layers.push_back(make_layer("cuticle", 1.5, 0.03, Spectrum(0.1), Spectrum(20.0), Spectrum(0.8)));
  s.layers[0].bottom_roughness = 0.5;
  s.layers.push_back(make_layer("mesophyll", 1.4, 0.2, Spectrum(1.0, 0.3, 2.0), Spectrum(10.0), Spectrum(0.3)));
  s.layers[1].bottom_roughness = 0.2;
  s.below.ior = 1.0;
  ASSERT_EQ(validate_stack(s), "");
  const glm::dvec3 wo = from_angle(30.0);
  const RandomWalkSurface surface(s, kRandomHero, RandomWalkOptions{});
  RunningStats est[3], walk[3];
  sky_furnace(surface, wo, 37, 100000, est, -1.0);
  walk_albedo(s, wo, 38, 100000, walk, WalkResult::Side::Bottom);
  for (int c = 0; c < 3; ++c) {
    const double se = std::hypot(est[c].standard_error(), walk[c].standard_error());
    EXPECT_TRUE(WithinKSigma(est[c].mean(), walk[c].mean(), se)) << "channel " << c;
    EXPECT_GT(walk[c].mean(), 20.0 * se) << "channel " << c;
  }
}

}  // namespace
}  // namespace lamina
