// The second step of a render job (render_job.h): what the layered materials need before the
// first ray. --subsurface auto chooses a mode per material; the table mode builds or loads its
// tables; the lambert mode computes its albedos; each material's mode reports what it leaves
// out; an approximate walk (--similarity-after) measures its bias. The lines for the user go to
// the log, the header keys (lamina:ignored:*, lamina:similarity_bias:*) to `ignored` and
// `similarity_bias`, and the result to `layered`, which the integrator reads.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "renderer/image/image_io.h"
#include "renderer/layered/layered_shading.h"
#include "renderer/layered/layered_tables.h"
#include "renderer/layered/spectral_tables.h"
#include "renderer/layered/subsurface_auto.h"
#include "renderer/layered/subsurface_mode.h"
#include "renderer/surfaces/random_walk_surface.h"

namespace lamina {

class Camera;
class Scene;
class WalkCache;
struct RenderLog;

// What the preparation reads.
struct ShadingInputs {
  const LayeredBindings* bindings = nullptr;
  const std::vector<std::string>* material_names = nullptr;  // glTF material names, by slot
  const Scene* scene = nullptr;
  const Camera* camera = nullptr;
  int width = 0, height = 0;  // the image (auto's visibility grid)
  SubsurfaceChoice subsurface;
  TableSettings::Method table_method = TableSettings::Method::AddingDoubling;
  RandomWalkOptions walk;
  WalkCache* cache = nullptr;  // null: none
  // The spectral mode: per material slot, its file's chromophore layers (null: none); null in
  // the RGB mode. The table and lambert modes then also get their grid (spectral_tables.h).
  const std::vector<std::shared_ptr<const SpectralStack>>* spectral = nullptr;
};

struct PreparedShading {
  std::vector<AutoChoice> choices;  // --subsurface auto: per material slot; else empty
  std::unique_ptr<LayeredTables> tables;
  std::unique_ptr<SpectralTables> spectral_tables;  // the spectral mode's, when a material needs them
  Metadata ignored;          // lamina:ignored:<material>
  Metadata similarity_bias;  // lamina:similarity_bias:<material>
  LayeredShading layered;    // for the integrator; points into `tables` and the inputs' bindings
};

// Fills *out (in place: `layered` points into it). Throws what the tables or the cache throw.
void prepare_shading(const ShadingInputs& in, const RenderLog& log, PreparedShading* out);

}  // namespace lamina
