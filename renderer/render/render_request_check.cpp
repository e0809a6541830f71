#include "renderer/render/render_request_check.h"

#include <algorithm>
#include <string>

#include "renderer/render/walk_option_table.h"
#include "renderer/util/string_format.h"

namespace lamina {
namespace {

bool given(const RenderRequest& r, const std::string& flag) {
  return std::find(r.given.begin(), r.given.end(), flag) != r.given.end();
}

[[noreturn]] void refuse(const std::string& message) { throw RenderRequestError(message); }

void check_size(const RenderRequest& r) {
  const RenderSettings& s = r.settings;
  if (static_cast<double>(s.width) * s.height * s.spp > kMaxPathSamples) refuse("--width x --height x --spp exceeds 1e12 paths");
  const PixelRegion& c = s.crop;
  if (c.empty() && !given(r, "--crop")) return;  // the whole image (an empty region given as a crop is refused)
  if (!(c.x0 >= 0 && c.y0 >= 0 && c.x0 < c.x1 && c.y0 < c.y1 && c.x1 <= s.width && c.y1 <= s.height))
    refuse(string_printf("--crop %d,%d,%d,%d: expected X0 < X1 <= --width (%d) and Y0 < Y1 <= --height (%d)", c.x0, c.y0, c.x1,
                         c.y1, s.width, s.height));
}

void check_modes(const RenderRequest& r) {
  const SubsurfaceChoice& choice = r.subsurface;
  if (!choice.automatic && choice.mode != SubsurfaceMode::RandomWalk)
    for (const WalkOptionSpec& spec : kWalkOptionTable)
      if (given(r, spec.flag))
        refuse(std::string(spec.flag) + " is only meaningful with --subsurface random-walk or auto (the " +
               subsurface_mode_name(choice.mode) + " mode runs no walk)");
  const RenderSettings& s = r.settings;
  if (given(r, "--pilot-spp") && !(s.noise_threshold > 0.0)) refuse("--pilot-spp is only meaningful with --noise-threshold");
  if (s.noise_threshold > 0.0 && s.pilot_spp > s.spp)
    refuse("--pilot-spp " + std::to_string(s.pilot_spp) + " exceeds --spp " + std::to_string(s.spp));
  if (given(r, "--tolerance") && !choice.automatic) refuse("--tolerance is only meaningful with --subsurface auto");
  if (choice.automatic && !(choice.tolerance > 0.0)) refuse("--subsurface auto needs --tolerance E (e.g. 0.05)");
  if (given(r, "--table-method") && !choice.automatic && choice.mode != SubsurfaceMode::Table)
    refuse("--table-method is only meaningful with --subsurface table or auto");
}

}  // namespace

void check_render_request(const RenderRequest& r) {
  check_size(r);
  if (r.png_path.empty())
    for (const char* png_only : {"--exposure", "--tone-curve"})
      if (given(r, png_only)) refuse(std::string(png_only) + " is only meaningful with --png (the EXR stays linear)");
  check_modes(r);
}

void check_table_method(const RenderRequest& r, const LayeredBindings& bindings, const std::vector<std::string>& names) {
  const SubsurfaceChoice& choice = r.subsurface;
  if (r.table_method != TableSettings::Method::MonteCarlo) return;
  if (!choice.automatic && choice.mode != SubsurfaceMode::Table) return;
  for (std::size_t i = 0; i < bindings.by_material.size(); ++i) {
    const LayeredMaterial* m = bindings.by_material[i].get();
    if (!m || !m->base_stack().energy_conserving_rough()) continue;
    const std::string name = i < names.size() ? names[i] : std::to_string(i);
    refuse("--table-method walk: material " + name + " (" + m->source() +
           ") has energy-conserving rough interfaces, whose walk-built tables would hold only the scattered light; "
           "use the default --table-method adding-doubling");
  }
}

}  // namespace lamina
