// Shading::surface_at (renderer/layered/shading.h): the one call that gives the integrator the
// surface at a hit. For each kind of material and each layered mode it builds the surface kind
// the mode names (the stochastic walk is not a Bsdf), with the normals turned towards the viewer
// from either side; the SurfaceStorage it builds in destroys what it held.
#include <string>

#include <gtest/gtest.h>
#include <glm/geometric.hpp>

#include "renderer/layered/layered_shading.h"
#include "renderer/layered/material_binding.h"
#include "renderer/layered/shading.h"
#include "renderer/scene/scene.h"
#include "renderer/scene/scene_gltf.h"
#include "renderer/surfaces/first_order_surface.h"
#include "renderer/surfaces/metallic_roughness_surface.h"
#include "renderer/surfaces/random_walk_surface.h"
#include "renderer/surfaces/surface_storage.h"
#include "tests/renderer/gltf_fixture.h"

namespace lamina {
namespace {

using testing::TempDir;

// The leaf square (tests/renderer/gltf_fixture.h): layered, or plain metallic-roughness.
SceneDesc square(const TempDir& dir, bool layered) {
  testing::write_leaf_square(dir / "square.gltf", layered);
  return load_gltf(dir / "square.gltf");
}

// The hit of the ray from (0.1, 0.2, z) straight through the square.
SurfaceHit hit_from(const Scene& scene, double z) {
  RayCounters counters;
  SurfaceHit hit;
  const Ray ray{{0.1, 0.2, z}, {0.0, 0.0, z > 0.0 ? -1.0 : 1.0}};
  EXPECT_TRUE(scene.intersect(ray, &hit, counters));
  return hit;
}

TEST(Shading, PlainMaterialIsItsMetallicRoughnessBsdf) {
  TempDir dir("shading-plain");
  const Scene scene{square(dir, false)};
  const Shading shading(scene.desc(), nullptr);
  PathShading path = shading.start_path(0, 0, 0, nullptr);
  SurfaceStorage storage;
  ShadingGeometry g;
  const Surface& surface = shading.surface_at(hit_from(scene, 2.0), {0.0, 0.0, 1.0}, path, storage, &g);
  EXPECT_NE(dynamic_cast<const MetallicRoughnessSurface*>(&surface), nullptr);
  EXPECT_NE(dynamic_cast<const Bsdf*>(&surface), nullptr);
  EXPECT_GT(g.wo.z, 0.99);
}

TEST(Shading, EachLayeredModeBuildsItsSurfaceKind) {
  TempDir dir("shading-modes");
  SceneDesc desc = square(dir, true);
  const LayeredBindings bound = bind_layered_materials(desc, "");
  ASSERT_NE(bound.get(0), nullptr);
  const Scene scene{std::move(desc)};
  for (const double z : {2.0, -2.0}) {  // from the front and from behind
    const SurfaceHit hit = hit_from(scene, z);
    const glm::dvec3 wo_world{0.0, 0.0, z > 0.0 ? 1.0 : -1.0};
    for (const SubsurfaceMode mode : {SubsurfaceMode::RandomWalk, SubsurfaceMode::FirstOrder, SubsurfaceMode::Lambert}) {
      LayeredShading layered;
      layered.bindings = &bound;
      layered.mode = mode;
      const Shading shading(scene.desc(), &layered);
      PathShading path = shading.start_path(1, 2, 3, nullptr);
      SurfaceStorage storage;
      ShadingGeometry g;
      const Surface& surface = shading.surface_at(hit, wo_world, path, storage, &g);
      const std::string what = std::string(subsurface_mode_name(mode)) + (z > 0.0 ? ", front" : ", behind");
      // The frame faces the viewer from either side.
      EXPECT_GT(glm::dot(g.frame.n, wo_world), 0.99) << what;
      EXPECT_GT(g.ng.z * wo_world.z, 0.99) << what;
      EXPECT_GT(g.wo.z, 0.99) << what;
      const bool is_bsdf = dynamic_cast<const Bsdf*>(&surface) != nullptr;
      switch (mode) {
        case SubsurfaceMode::RandomWalk:
          EXPECT_NE(dynamic_cast<const RandomWalkSurface*>(&surface), nullptr) << what;
          EXPECT_FALSE(is_bsdf) << what;  // stochastic: nothing to evaluate
          break;
        case SubsurfaceMode::FirstOrder:
          EXPECT_NE(dynamic_cast<const FirstOrderSurface*>(&surface), nullptr) << what;
          EXPECT_TRUE(is_bsdf) << what;
          break;
        case SubsurfaceMode::Lambert:
          EXPECT_NE(dynamic_cast<const LambertSurface*>(&surface), nullptr) << what;
          EXPECT_TRUE(is_bsdf) << what;
          break;
        case SubsurfaceMode::Table:
          break;
      }
    }
  }
}

// A surface that counts its destructions.
struct Counted final : Surface {
  explicit Counted(int* destroyed) : destroyed_(destroyed) {}
  ~Counted() override { ++*destroyed_; }
  bool scatter(const glm::dvec3&, Rng&, LightDirection*, int, LightSampler*, SurfaceScatter*) const override {
    return false;
  }
  int* destroyed_;
};

TEST(SurfaceStorage, DestroysWhatItHeldOnReuseAndAtTheEnd) {
  int destroyed = 0;
  {
    SurfaceStorage storage;
    storage.emplace<Counted>(&destroyed);
    EXPECT_EQ(destroyed, 0);
    storage.emplace<Counted>(&destroyed);
    EXPECT_EQ(destroyed, 1);
  }
  EXPECT_EQ(destroyed, 2);
}

}  // namespace
}  // namespace lamina
