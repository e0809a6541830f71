// The lambert mode's albedo, 2 int R_diffuse(mu) mu dmu, two ways: by the walk with
// cosine-weighted incidence (materials/tables/albedo.h) and by adding-doubling minus the exact
// unscattered part. They must agree within 4 of the walk's standard errors (plus the
// adding-doubling discretisation, ~1e-4) on stacks that exercise every piece: index-matched,
// a film over glass (critical angle inside), a semi-infinite layer, a Lambert substrate, the
// composite skin and the leaf (g = 0.9).
#include "materials/tables/albedo.h"

#include <cmath>
#include <string>

#include <gtest/gtest.h>

#include "materials/adding_doubling/adding_doubling.h"
#include "materials/analytic/first_order.h"  // gauss_legendre
#include "materials/interfaces/fresnel.h"
#include "materials/stack/stack.h"
#include "materials/stack/stack_file.h"
#include "tests/materials/stack_fixtures.h"

namespace lamina {
namespace {

std::string source(const std::string& rel) { return std::string(LAMINA_SOURCE_DIR) + "/" + rel; }

void expect_same(const LayerStack& stack, const std::string& name) {
  Spectrum se;
  const Spectrum walk = diffuse_bihemispherical_albedo(stack, 1 << 16, 5, &se);
  const Spectrum ad = diffuse_bihemispherical_albedo_adding_doubling(stack);
  for (int c = 0; c < kChannels; ++c) {
    EXPECT_NEAR(ad[c], walk[c], 4.0 * se[c] + 2e-4) << name << " channel " << c << " (se " << se[c] << ")";
    EXPECT_GE(ad[c], 0.0);
    EXPECT_LE(ad[c], 1.0);
  }
}

// Under a diffuse top the delta lobe is the top's mirror F(mu) alone (zeroth_order_above_rough):
// the light that crossed it comes back spread, unscattered or not, and belongs to the albedo,
// which is then R_h less 2 int F(mu) mu dmu, to the solver's quadrature (1e-6). A clear plate
// makes the difference large: taken as a smooth plate, its internal reflections would be a
// mirror too.
TEST(DiffuseAlbedo, UnderADiffuseTopOnlyTheTopsMirrorIsLeftOut) {
  LayerStack plate;
  plate.top_diffuse = true;
  plate.layers.push_back(make_layer("clear", 1.5, 0.5, Spectrum(0.0, 0.2, 1.0), Spectrum(0.0), Spectrum(0.0)));
  plate.below.ior = 1.0;
  double mirror = 0.0;
  double x[64], w[64];
  gauss_legendre(64, 0.0, 1.0, x, w);
  for (int i = 0; i < 64; ++i) mirror += 2.0 * x[i] * w[i] * fresnel_dielectric(x[i], 1.0, 1.5);
  const Spectrum r_h = adding_doubling_totals(plate, 1.0).R_hemispherical;
  const Spectrum a = diffuse_bihemispherical_albedo_adding_doubling(plate);
  for (int c = 0; c < kChannels; ++c) EXPECT_NEAR(a[c], r_h[c] - mirror, 1e-6) << "channel " << c;
  // The walk's albedo counts the same light (every exit through the diffuse top), on the plate
  // and on a scattering leaf under it, from air and from a denser medium above.
  expect_same(plate, "clear plate under a diffuse top");
  LayerStack leaf = plate;
  leaf.layers[0] = make_layer("mesophyll", 1.5, 0.2, Spectrum(0.3, 1.0, 3.0), Spectrum(20.0), Spectrum(0.6));
  expect_same(leaf, "scattering leaf under a diffuse top");
  leaf.above_ior = 1.7;
  expect_same(leaf, "the leaf under a denser medium");
}

TEST(DiffuseAlbedo, AddingDoublingAgreesWithTheWalk) {
  LayerStack matched;
  matched.above_ior = 1.0;
  matched.layers.push_back(make_layer("a", 1.0, 0.5, Spectrum(0.1, 0.5, 2.0), Spectrum(8.0), Spectrum(0.5)));
  matched.below.kind = Below::Kind::Dielectric;
  matched.below.ior = 1.0;
  expect_same(matched, "index-matched slab");

  LayerStack film = matched;
  film.layers[0].ior = 1.4;
  film.below.ior = 1.5;
  expect_same(film, "film over glass");

  LayerStack half;
  half.above_ior = 1.0;
  half.layers.push_back(make_layer("h", 1.33, kInfiniteThickness, Spectrum(0.05, 0.3, 1.0), Spectrum(10.0), Spectrum(0.8)));
  expect_same(half, "semi-infinite, g 0.8");

  LayerStack lambert = film;
  lambert.below.kind = Below::Kind::Lambert;
  lambert.below.albedo = Spectrum(0.6, 0.3, 0.1);
  expect_same(lambert, "film over a Lambert substrate");

  expect_same(load_stack_file(source("scenes/materials/skin.json")), "skin.json");
  expect_same(load_stack_file(source("scenes/materials/leaf.json")), "leaf.json");
}

}  // namespace
}  // namespace lamina
