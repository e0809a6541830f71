// The Lee Perry-Smith head's texture coordinates follow glTF's convention (origin at the top of
// the image). The asset once stored OpenGL-style coordinates (origin at the bottom): the loader
// was right and every texture landed upside down on the face (lips on the chin, the oil T-zone
// on the chest), and no test caught it because each test checked the loader, not the asset.
// These tests check the asset as the renderer loads it, against the geometry of the face.
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "renderer/scene/scene_gltf.h"

namespace lamina {
namespace {

const std::string kHead = std::string(LAMINA_SOURCE_DIR) + "/scenes/lee_perry_smith_head/LeePerrySmith_textured.gltf";
const std::string kHeadSkin = std::string(LAMINA_SOURCE_DIR) + "/scenes/head_skin/head_skin.gltf";

// The head mesh of a scene: the one with the most vertices.
const Mesh& head_mesh(const SceneDesc& scene) {
  const Mesh* best = &scene.meshes.front();
  for (const Mesh& m : scene.meshes)
    if (m.positions.size() > best->positions.size()) best = &m;
  return *best;
}

// Pearson correlation of height (world y) and texture v over the front of the face (normals
// towards +z, the way the head looks, within one unit, ~3 cm, of the midline). In a glTF
// texture v grows downwards in the image, and the atlas (Map-COL.jpg) draws the face upright, so
// going up the face v must fall: the correlation is strongly negative (-0.81 for this asset).
// Stored upside down it is +0.81.
double height_v_correlation(const Mesh& mesh) {
  double n = 0, sy = 0, sv = 0, syy = 0, svv = 0, syv = 0;
  for (std::size_t i = 0; i < mesh.positions.size(); ++i) {
    if (mesh.normals[i].z < 0.3f || std::abs(mesh.positions[i].x) > 1.0f) continue;
    const double y = mesh.positions[i].y, v = mesh.texcoords[i].y;
    n += 1;
    sy += y;
    sv += v;
    syy += y * y;
    svv += v * v;
    syv += y * v;
  }
  const double cov = syv / n - (sy / n) * (sv / n);
  return cov / std::sqrt((syy / n - (sy / n) * (sy / n)) * (svv / n - (sv / n) * (sv / n)));
}

void expect_face_upright(const std::string& path) {
  const SceneDesc scene = load_gltf(path);
  const Mesh& mesh = head_mesh(scene);
  ASSERT_EQ(mesh.texcoords.size(), mesh.positions.size()) << path;
  ASSERT_EQ(mesh.normals.size(), mesh.positions.size()) << path;
  EXPECT_LT(height_v_correlation(mesh), -0.5) << path << ": texture v rises up the face: the texture lands upside down";

  // The tip of the nose (the vertex furthest towards +z) sits on the atlas's nose tip, read off
  // Map-COL.jpg: centred (u = 0.50), 40 % of the image height from the top (the eyes at 27 %,
  // the mouth at 46 %). Upside down it reads v = 0.61.
  std::size_t tip = 0;
  for (std::size_t i = 1; i < mesh.positions.size(); ++i)
    if (mesh.positions[i].z > mesh.positions[tip].z) tip = i;
  EXPECT_NEAR(mesh.texcoords[tip].x, 0.50, 0.03) << path;
  EXPECT_NEAR(mesh.texcoords[tip].y, 0.40, 0.03) << path;
}

TEST(HeadAsset, TextureIsUprightOnTheFace) { expect_face_upright(kHead); }

// head_skin references the same geometry; its maps (blood, oil, freckles) are drawn in the
// atlas's image space, so they follow the same coordinates.
TEST(HeadAsset, HeadSkinSceneUsesTheUprightCoordinates) { expect_face_upright(kHeadSkin); }

}  // namespace
}  // namespace lamina
