// The library entry point of a render: what `lamina render` does between parsing its arguments
// and printing its summary, and what `lamina batch` runs in-process for each job. It loads the
// scene, binds the layered materials, decides the --subsurface mode per material (auto), builds
// or loads tables and Lambert albedos (through the walk cache), renders, and writes the EXR (and
// PNG) with the metadata of docs/contracts.md ("lamina render").
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <string>
#include <utility>
#include <vector>

#include "materials/tables/layered_table.h"
#include "renderer/image/image_io.h"
#include "renderer/image/tone_map.h"
#include "renderer/layered/material_binding.h"
#include "renderer/layered/subsurface_mode.h"
#include "renderer/render/film.h"
#include "renderer/surfaces/random_walk_surface.h"

namespace lamina {

struct RenderRequest {
  std::string scene_path;  // .gltf or .glb
  std::string out_path;    // the EXR
  std::string png_path;    // "" for none: an sRGB preview
  ToneMap tone_map;        // of the PNG (the EXR stays linear)
  std::string camera_name;  // "" for the first camera (none: one framing the scene)
  std::string materials_map_path;  // --materials ("" for none)
  // Stacks given in memory (lamina batch's variants), as if the map named them; they win over
  // the map and the extras.
  std::vector<InlineStack> inline_stacks;
  // --stack (renderer/layered/stack_assignment.h): stack files assigned from the command line.
  std::vector<StackAssignment> stacks;
  std::string env;  // --env: a number, R,G,B or an image file ("" for black)
  // --subsurface (and --tolerance with auto): renderer/layered/subsurface_mode.h.
  SubsurfaceChoice subsurface = SubsurfaceChoice::fixed(SubsurfaceMode::RandomWalk);
  std::string cache_dir;   // "" for no walk cache (renderer/layered/walk_cache.h)
  // How the table mode builds its tables (materials/tables/layered_table.h): adding-doubling (falling
  // back to the walk where it cannot resolve a lobe) or the walk.
  TableSettings::Method table_method = TableSettings::Method::AddingDoubling;
  // random-walk mode: the walk's options (LayeredShading::walk). With similarity_after >= 0
  // (approximate) the bias on each material's diffuse albedo is measured, printed and recorded
  // (lamina:similarity_bias:<material>).
  RandomWalkOptions walk;
  RenderSettings settings;  // width, height, spp, seed, max depth, threads (`layered` is set here)
  std::string command_line;  // lamina:command: the command that reproduces the image
  Metadata extra_metadata;   // appended to the header (lamina batch's job id and hash)
  // For callers other than the command line (the Python package, docs/python.md): the samples
  // done and planned, from the rendering threads, instead of the terminal's progress bar. It may
  // throw to stop the render; the exception leaves render_job and nothing is written.
  std::function<void(std::uint64_t done, std::uint64_t total)> on_progress;
  // Set from any thread to stop the render within a path (RenderProgress::cancel): render_job
  // then throws RenderCancelled (renderer/render/film.h) and writes nothing.
  const std::atomic<bool>* cancel = nullptr;
  bool write_files = true;  // false: out_path and png_path are not written (the result holds the image)
  // The options the caller set, by their `lamina render` flags ("--exposure", "--guiding", ...):
  // those that would not act with the others are refused (renderer/render/render_request_check.h).
  std::vector<std::string> given;
};

// What auto chose for one layered material: a mode name, or "lambert-hidden" (not seen by camera
// rays, not predicted). The same as the header's lamina:auto_mode:<material>.
struct MaterialModeChoice {
  std::string material;  // glTF material name
  std::string mode;
  std::string reason;    // lamina:auto:<material>
};

struct RenderResult {
  std::string camera;   // the camera's name
  double seconds = 0.0;  // the render itself (not the scene loading, tables, albedos)
  RenderStats stats;
  int layered_materials = 0;
  std::vector<MaterialModeChoice> auto_choices;  // empty unless --subsurface auto
  Metadata metadata;  // as written to the EXR
  // The image as written to the EXR: RGB, the extra channels (sample counts, AOVs) and where
  // the pixels sit in the full image (a crop).
  Image image;
  std::vector<ExtraChannel> channels;
  DataWindow window;
};

// Lines for the user: `info` for stdout, `warning` for stderr (without a "lamina render: "
// prefix: the caller adds its own). Either may be empty (silent).
struct RenderLog {
  std::function<void(const std::string&)> info, warning;
};

// Throws std::runtime_error (SceneError, StackFileError messages, image errors, an unknown
// camera) with one line naming the file.
RenderResult render_job(const RenderRequest& request, const RenderLog& log = {});

// The selected AOVs as the header and --aovs write them: "albedo,normal,depth,variance" or a
// part of it, "none" for none. parse_aov_names reads such a list ("all" for every one); false on
// an unknown name, which *bad then holds.
std::string aov_names(const AovSelection& aovs);
bool parse_aov_names(const std::string& list, AovSelection* aovs, std::string* bad);

// Mean samples per pixel in the image (settings.spp unless adaptive sampling or a time limit
// varied it).
double mean_spp(const RenderStats& stats, const RenderSettings& settings);

}  // namespace lamina
