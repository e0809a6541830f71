#include "renderer/render/render_metadata.h"

#include <sstream>
#include <string>

#include "renderer/render/spectral_option.h"
#include "renderer/render/walk_option_table.h"
#include "renderer/util/string_format.h"
#include "renderer/util/version.h"

namespace lamina {
namespace {

struct HeaderKey {
  const char* key;
  std::string (*value)(const HeaderInputs&);
};

const RenderSettings& settings(const HeaderInputs& in) { return in.request.settings; }
const RayCounters& rays(const HeaderInputs& in) { return in.result.stats.rays; }
std::string real(double v) { return string_printf("%.17g", v); }
// The shortest form the standard streams print (6 significant digits).
std::string streamed(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

// What names the image: the previews' header too.
const HeaderKey kIdentityKeys[] = {
    {"lamina:version", [](const HeaderInputs&) { return std::string(lamina_version()); }},
    {"lamina:command", [](const HeaderInputs& in) { return in.request.command_line; }},
    {"lamina:scene", [](const HeaderInputs& in) { return in.request.scene_path; }},
    {"lamina:camera", [](const HeaderInputs& in) { return in.result.camera; }},
};
// The request (the walk options follow, from kWalkOptionTable).
const HeaderKey kRequestKeys[] = {
    {"lamina:spp", [](const HeaderInputs& in) { return std::to_string(settings(in).spp); }},
    {"lamina:seed", [](const HeaderInputs& in) { return std::to_string(settings(in).seed); }},
    {"lamina:max_depth", [](const HeaderInputs& in) { return std::to_string(settings(in).max_depth); }},
    {"lamina:env", [](const HeaderInputs& in) { return in.request.env.empty() ? std::string("0") : in.request.env; }},
    {"lamina:subsurface", [](const HeaderInputs& in) { return in.request.subsurface.name(); }},
};
// The sampling settings and what the render did.
const HeaderKey kSamplingKeys[] = {
    {"lamina:noise_threshold", [](const HeaderInputs& in) { return real(settings(in).noise_threshold); }},
    {"lamina:pilot_spp",
     [](const HeaderInputs& in) { return std::to_string(settings(in).noise_threshold > 0.0 ? settings(in).pilot_spp : 0); }},
    {"lamina:time_limit", [](const HeaderInputs& in) { return real(settings(in).time_limit); }},
    {"lamina:time_limit_reached", [](const HeaderInputs& in) { return std::string(in.result.stats.time_limit_reached ? "1" : "0"); }},
    {"lamina:mean_spp", [](const HeaderInputs& in) { return string_printf("%.6g", mean_spp(in.result.stats, settings(in))); }},
    {"lamina:aovs", [](const HeaderInputs& in) { return aov_names(settings(in).aovs); }},
    {"lamina:clamp", [](const HeaderInputs& in) { return real(settings(in).clamp); }},
    {"lamina:clamped_samples", [](const HeaderInputs& in) { return std::to_string(in.result.stats.clamped_samples); }},
    {"lamina:seconds", [](const HeaderInputs& in) { return streamed(in.result.seconds); }},
    {"lamina:rays_closest", [](const HeaderInputs& in) { return std::to_string(rays(in).closest); }},
    {"lamina:rays_camera", [](const HeaderInputs& in) { return std::to_string(rays(in).camera); }},
    {"lamina:rays_shadow", [](const HeaderInputs& in) { return std::to_string(rays(in).shadow); }},
    {"lamina:layered_materials", [](const HeaderInputs& in) { return std::to_string(in.result.layered_materials); }},
    {"lamina:scatter_events", [](const HeaderInputs& in) { return std::to_string(rays(in).scatter_events); }},
};

template <std::size_t N>
void add_keys(const HeaderKey (&keys)[N], const HeaderInputs& in, Metadata* meta) {
  for (const HeaderKey& k : keys) meta->emplace_back(k.key, k.value(in));
}

}  // namespace

Metadata identity_metadata(const HeaderInputs& in) {
  Metadata meta;
  add_keys(kIdentityKeys, in, &meta);
  return meta;
}

Metadata render_metadata(const HeaderInputs& in, const Metadata& similarity_bias, const Metadata& ignored) {
  Metadata meta = identity_metadata(in);
  add_keys(kRequestKeys, in, &meta);
  for (const WalkOptionSpec& spec : kWalkOptionTable) meta.emplace_back(spec.exr_key, walk_option_text(spec, in.request.walk));
  if (settings(in).spectral) meta.emplace_back(kSpectralOption.exr_key, kSpectralOption.exr_value);
  add_keys(kSamplingKeys, in, &meta);
  if (!in.request.stacks.empty()) meta.emplace_back(kStackExrKey, stack_assignments_text(in.request.stacks));
  const PixelRegion& crop = settings(in).crop;
  if (!crop.empty()) meta.emplace_back("lamina:crop", string_printf("%d,%d,%d,%d", crop.x0, crop.y0, crop.x1, crop.y1));
  meta.insert(meta.end(), similarity_bias.begin(), similarity_bias.end());
  meta.insert(meta.end(), ignored.begin(), ignored.end());
  if (in.request.subsurface.automatic) {
    meta.emplace_back("lamina:tolerance", streamed(in.request.subsurface.tolerance));
    for (const MaterialModeChoice& c : in.result.auto_choices) {
      meta.emplace_back("lamina:auto:" + c.material, c.reason);
      // The same choice for programs (lamina batch's auto_choices column).
      meta.emplace_back("lamina:auto_mode:" + c.material, c.mode);
    }
  }
  meta.insert(meta.end(), in.request.extra_metadata.begin(), in.request.extra_metadata.end());
  return meta;
}

}  // namespace lamina
