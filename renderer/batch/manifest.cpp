// Batch manifests: the schema's parsing and validation (see manifest.h).
#include "renderer/batch/manifest.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <set>

#include "materials/stack/stack_parameters.h"
#include "renderer/batch/manifest_where.h"
#include "renderer/image/image_compare.h"
#include "renderer/render/spectral_option.h"
#include "renderer/scene/gltf_document.h"
#include "materials/stack/json_keys.h"
#include "materials/stack/decimal.h"
#include "materials/stack/json_limits.h"
#include "materials/stack/text_file.h"

namespace lamina {
namespace batch_detail {

std::vector<StackPathStep> stack_path_steps(const std::string& path, const Where& where) {
  try {
    return split_stack_path(path);
  } catch (const StackParameterError&) {
    // One message for every malformed path, whatever split_stack_path's reason: the example
    // shows the grammar better than the first character it stumbled on.
    where.fail("bad stack path '" + path + "' (expected e.g. layers[1].components[0].fraction)");
  }
}

}  // namespace batch_detail

namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using batch_detail::Where;

std::string type_name(const json& j) { return j.type_name(); }

void check_keys(const json& object, const Where& where, std::initializer_list<const char*> allowed) {
  if (!object.is_object()) where.fail("expected an object, got " + type_name(object));
  if (const std::string* key = first_unknown_key(object, allowed))
    where.key(*key).fail("unknown key (expected one of: " + key_list(allowed) + ")");
}

std::string get_string(const json& j, const Where& where) {
  if (!j.is_string()) where.fail("expected a string, got " + type_name(j));
  return j.get<std::string>();
}

long long get_integer(const json& j, const Where& where, long long lo, long long hi) {
  if (!j.is_number_integer() && !j.is_number_unsigned()) where.fail("expected an integer, got " + j.dump());
  const long long v = j.is_number_unsigned() ? static_cast<long long>(std::min<std::uint64_t>(j.get<std::uint64_t>(), 1ull << 62))
                                             : j.get<long long>();
  if (v < lo || v > hi) where.fail(j.dump() + " is out of range [" + std::to_string(lo) + ", " + std::to_string(hi) + "]");
  return v;
}

// Names become parts of file names: letters, digits, '.', '-', '_', not starting with '.' or
// '-', and no "__" (the separator of job ids, so ids are unambiguous).
void check_name(const std::string& s, const Where& where) {
  bool ok = !s.empty() && s.size() <= 64 && std::isalnum(static_cast<unsigned char>(s[0]));
  for (char c : s) ok = ok && (std::isalnum(static_cast<unsigned char>(c)) || c == '.' || c == '-' || c == '_');
  if (!ok || s.find("__") != std::string::npos)
    where.fail("name '" + s + "' must be 1-64 letters, digits, '.', '-' or '_', start with a letter or digit, and not contain '__'");
}
std::string get_name(const json& j, const Where& where) {
  const std::string s = get_string(j, where);
  check_name(s, where);
  return s;
}

// A path from the manifest, resolved against its directory; must name an existing file.
std::string get_file(const json& j, const Where& where, const std::string& directory) {
  const std::string s = get_string(j, where);
  if (s.empty()) where.fail("empty file name");
  fs::path p(s);
  if (p.is_relative()) p = fs::path(directory) / p;
  p = p.lexically_normal();
  std::error_code ec;
  if (!fs::is_regular_file(p, ec)) where.fail("file '" + p.string() + "' does not exist");
  return p.string();
}

std::string join(const std::set<std::string>& names) {
  std::string s;
  for (const std::string& n : names) s += (s.empty() ? "'" : ", '") + n + "'";
  return s.empty() ? "none" : s;
}

// Parses "x" or "r,g,b" as finite numbers; false if the text is anything else.
bool is_number_list(const std::string& s) {
  int count = 0;
  std::size_t start = 0;
  while (true) {
    const std::size_t comma = s.find(',', start);
    const std::string part = s.substr(start, comma == std::string::npos ? std::string::npos : comma - start);
    double v = 0.0;
    if (!parse_real(part, &v).empty()) return false;  // materials/stack/decimal.h: no hex, nan or overflow
    ++count;
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  return count == 1 || count == 3;
}

// The environment of a lighting set-up: a number, [r, g, b], "r,g,b" or a file.
void parse_env(const json& j, const Where& where, const std::string& directory, LightingSpec& out) {
  auto check = [&](const json& v, const Where& w) {
    if (!v.is_number() || !std::isfinite(v.get<double>()) || v.get<double>() < 0.0)
      w.fail("expected a finite radiance >= 0, got " + v.dump());
  };
  if (j.is_number()) {
    check(j, where);
    out.env = j.dump();
  } else if (j.is_array()) {
    if (j.size() != 3) where.fail("expected [r, g, b], got " + std::to_string(j.size()) + " values");
    for (std::size_t i = 0; i < 3; ++i) check(j[i], where.at(i));
    out.env = j[0].dump() + "," + j[1].dump() + "," + j[2].dump();
  } else if (j.is_string() && is_number_list(j.get<std::string>())) {
    out.env = j.get<std::string>();
  } else if (j.is_string()) {
    out.env = get_file(j, where, directory);
    out.env_is_file = true;
  } else {
    where.fail("expected a number, [r, g, b] or an EXR/HDR file, got " + j.dump());
  }
}

// One entry of "modes": a fixed mode as a string, or {"name", "subsurface", "tolerance"}. The
// names are those of renderer/layered/subsurface_mode.h.
ModeSpec parse_mode(const json& j, const Where& where) {
  const char* const auto_form = "{\"subsurface\": \"auto\", \"tolerance\": 0.05} (optional \"name\")";
  ModeSpec mode;
  if (j.is_string()) {
    const std::string name = j.get<std::string>();
    if (name == kAutoSubsurfaceName) where.fail("mode \"auto\" needs a tolerance: write " + std::string(auto_form));
    if (!parse_subsurface_choice(name, &mode.subsurface))
      where.fail("unknown mode '" + name + "' (expected " + subsurface_mode_names(", ") + " or " + auto_form + ")");
    mode.name = name;
    return mode;
  }
  if (!j.is_object()) where.fail("expected a mode name or an object " + std::string(auto_form) + ", got " + type_name(j));
  check_keys(j, where, {"name", "subsurface", "tolerance"});
  if (!j.contains("subsurface")) where.fail("missing \"subsurface\" (" + subsurface_choice_expected() + ")");
  const std::string subsurface = get_string(j["subsurface"], where.key("subsurface"));
  if (!parse_subsurface_choice(subsurface, &mode.subsurface))
    where.key("subsurface").fail("unknown mode '" + subsurface + "' (expected " + subsurface_choice_expected() + ")");
  if (mode.subsurface.automatic) {
    if (!j.contains("tolerance")) where.fail("\"subsurface\": \"auto\" needs a \"tolerance\" (a relative error in (0, 1], e.g. 0.05)");
    const json& t = j["tolerance"];
    // The largest predicted relative RMS error a material may have (renderer/layered/subsurface_auto.h):
    // the range `lamina render --tolerance` accepts, checked here so a bad manifest fails before
    // any job renders.
    if (!t.is_number() || !std::isfinite(t.get<double>()) || !(t.get<double>() > 0.0) || t.get<double>() > 1.0)
      where.key("tolerance").fail("expected a relative error in (0, 1], got " + t.dump());
    mode.subsurface.tolerance = t.get<double>();
  } else if (j.contains("tolerance")) {
    where.key("tolerance").fail("a tolerance is only meaningful with \"subsurface\": \"auto\" (mode '" + subsurface + "' is fixed)");
  }
  if (j.contains("name")) {
    mode.name = get_name(j["name"], where.key("name"));
  } else {
    // Shortest text that reads back as the same double: 0.05 -> "auto-0.05".
    mode.name = mode.subsurface.automatic ? "auto-" + json(mode.subsurface.tolerance).dump() : subsurface;
    check_name(mode.name, where);
  }
  return mode;
}

JobSelector parse_selector(const json& j, const Where& where, const Manifest& m) {
  check_keys(j, where, {"scene", "variant", "lighting", "mode", "spp"});
  JobSelector s;
  auto pick = [&](const char* key, auto names_of) {
    if (!j.contains(key)) return std::string();
    const std::string v = get_string(j[key], where.key(key));
    const std::vector<std::string> names = names_of();
    if (std::find(names.begin(), names.end(), v) == names.end()) {
      std::set<std::string> set(names.begin(), names.end());
      where.key(key).fail("'" + v + "' is not in the batch (" + join(set) + ")");
    }
    return v;
  };
  s.scene = pick("scene", [&] { std::vector<std::string> v; for (auto& x : m.scenes) v.push_back(x.name); return v; });
  s.variant = pick("variant", [&] { std::vector<std::string> v; for (auto& x : m.variants) v.push_back(x.name); return v; });
  s.lighting = pick("lighting", [&] { std::vector<std::string> v; for (auto& x : m.lighting) v.push_back(x.name); return v; });
  s.mode = pick("mode", [&] { std::vector<std::string> v; for (auto& x : m.modes) v.push_back(x.name); return v; });
  if (j.contains("spp")) {
    s.spp = static_cast<int>(get_integer(j["spp"], where.key("spp"), 1, 1 << 20));
    if (std::find(m.spp.begin(), m.spp.end(), s.spp) == m.spp.end()) where.key("spp").fail(std::to_string(s.spp) + " is not in the batch's spp");
  }
  return s;
}

// The manifest's key for `lamina render --stack`, from its flag: "stack".
std::string stack_key() { return std::string(kStackFlag).substr(2); }

// A "stack" value: one assignment or an array of them, each "FILE" or "NAME=FILE" as --stack
// takes it (parse_stack_assignment, with its messages), FILE relative to the manifest and
// existing, NAME a material of every scene in `scenes`.
std::vector<StackAssignment> parse_stacks(const json& j, const Where& where, const std::string& directory,
                                          const std::vector<std::pair<std::string, std::set<std::string>>>& scenes) {
  const json list = j.is_array() ? j : json::array({j});
  if (list.empty()) where.fail("expected \"FILE\", \"NAME=FILE\" or a non-empty array of them");
  std::vector<StackAssignment> out;
  for (std::size_t i = 0; i < list.size(); ++i) {
    const Where w = j.is_array() ? where.at(i) : where;
    const std::string text = get_string(list[i], w);
    StackAssignment a;
    std::string why;
    if (!parse_stack_assignment(text, &a, &why)) w.fail("'" + text + "': " + why);
    a.path = get_file(json(a.path), w, directory);
    for (const auto& [scene, names] : scenes)
      if (!a.all() && !names.count(a.material))
        w.fail("'" + text + "': no material '" + a.material + "' in scene '" + scene + "' (its materials: " + join(names) + ")");
    out.push_back(a);
  }
  return out;
}

// A "spectral" value: true or false, as the flag is given or not.
bool get_spectral(const json& j, const Where& where) {
  if (!j.is_boolean()) where.fail("expected true or false, got " + j.dump());
  return j.get<bool>();
}

void check_setting_value(const json& v, const Where& where) {
  auto finite = [](const json& x) { return x.is_number() && std::isfinite(x.get<double>()); };
  const bool ok = finite(v) || (v.is_string() && v.get<std::string>() == "inf") ||
                  (v.is_array() && v.size() == 3 && finite(v[0]) && finite(v[1]) && finite(v[2]));
  if (!ok) where.fail("expected a finite number, [r, g, b] or \"inf\", got " + v.dump());
}

}  // namespace

Manifest parse_manifest(const json& j, const std::string& path, const std::string& directory) {
  const Where root{path, ""};
  check_keys(j, root, {"lamina_batch", "settings", "scenes", "variants", "lighting", "modes", "spp", "comparisons", "contact_sheet", "description"});
  if (!j.contains("lamina_batch")) root.fail("missing \"lamina_batch\": 1 (the manifest format version)");
  if (get_integer(j["lamina_batch"], root.key("lamina_batch"), 1, 1000) != 1) root.key("lamina_batch").fail("only version 1 is known");
  if (j.contains("description")) get_string(j["description"], root.key("description"));

  Manifest m;
  m.path = path;
  m.directory = directory;

  if (j.contains("settings")) {
    const Where w = root.key("settings");
    const json& s = j["settings"];
    check_keys(s, w, {"width", "height", "seed", "max_depth", "stack", spectral_option_key()});
    if (s.contains("width")) m.settings.width = static_cast<int>(get_integer(s["width"], w.key("width"), 1, 16384));
    if (s.contains("height")) m.settings.height = static_cast<int>(get_integer(s["height"], w.key("height"), 1, 16384));
    if (s.contains("seed")) m.settings.seed = static_cast<std::uint64_t>(get_integer(s["seed"], w.key("seed"), 0, 1ll << 62));
    if (s.contains("max_depth")) m.settings.max_depth = static_cast<int>(get_integer(s["max_depth"], w.key("max_depth"), 0, 100000));
  }

  // Scenes: each with its glTF and the stacks its materials use.
  if (!j.contains("scenes")) root.fail("missing \"scenes\"");
  const Where ws = root.key("scenes");
  if (!j["scenes"].is_array() || j["scenes"].empty()) ws.fail("expected a non-empty array of scenes");
  std::vector<std::set<std::string>> scene_materials, scene_cameras;
  for (std::size_t i = 0; i < j["scenes"].size(); ++i) {
    const json& s = j["scenes"][i];
    const Where w = ws.at(i);
    check_keys(s, w, {"name", "file", "materials", "stack", spectral_option_key()});
    if (!s.contains("name")) w.fail("missing \"name\"");
    if (!s.contains("file")) w.fail("missing \"file\"");
    SceneSpec scene;
    scene.name = get_name(s["name"], w.key("name"));
    scene.file = get_file(s["file"], w.key("file"), directory);
    const std::string ext = fs::path(scene.file).extension().string();
    if (ext != ".gltf" && ext != ".glb") w.key("file").fail("'" + scene.file + "' is not a .gltf or .glb file");
    json gltf;
    try {
      gltf = read_gltf_json(scene.file);
    } catch (const GltfDocumentError& e) {
      w.key("file").fail(e.what());
    }
    scene_materials.push_back(gltf_material_names(gltf));
    scene_cameras.push_back(gltf_camera_names(gltf));
    if (s.contains("materials")) {
      const Where wm = w.key("materials");
      if (!s["materials"].is_object()) wm.fail("expected an object {glTF material name: stack file}");
      for (auto it = s["materials"].begin(); it != s["materials"].end(); ++it) {
        if (!scene_materials.back().count(it.key()))
          wm.key(it.key()).fail("'" + it.key() + "' is not a material of " + scene.file + " (materials: " + join(scene_materials.back()) + ")");
        scene.materials[it.key()] = get_file(it.value(), wm.key(it.key()), directory);
      }
    }
    const std::vector<std::pair<std::string, std::set<std::string>>> this_scene = {{scene.name, scene_materials.back()}};
    if (j.contains("settings") && j["settings"].contains(stack_key()))
      scene.stacks = parse_stacks(j["settings"][stack_key()], root.key("settings").key(stack_key()), directory, this_scene);
    if (s.contains(stack_key())) {
      const std::vector<StackAssignment> own = parse_stacks(s[stack_key()], w.key(stack_key()), directory, this_scene);
      scene.stacks.insert(scene.stacks.end(), own.begin(), own.end());
    }
    const char* spectral = spectral_option_key();
    if (j.contains("settings") && j["settings"].contains(spectral))
      scene.spectral = get_spectral(j["settings"][spectral], root.key("settings").key(spectral));
    if (s.contains(spectral)) scene.spectral = get_spectral(s[spectral], w.key(spectral));
    for (const SceneSpec& other : m.scenes)
      if (other.name == scene.name) w.key("name").fail("duplicate scene name '" + scene.name + "'");
    m.scenes.push_back(std::move(scene));
  }

  // Variants: overrides of material stacks. Default: one variant, "base", with none.
  if (j.contains("variants")) {
    const Where wv = root.key("variants");
    if (!j["variants"].is_array() || j["variants"].empty()) wv.fail("expected a non-empty array of variants");
    for (std::size_t i = 0; i < j["variants"].size(); ++i) {
      const json& v = j["variants"][i];
      const Where w = wv.at(i);
      check_keys(v, w, {"name", "overrides"});
      if (!v.contains("name")) w.fail("missing \"name\"");
      VariantSpec variant;
      variant.name = get_name(v["name"], w.key("name"));
      if (v.contains("overrides")) {
        const Where wo = w.key("overrides");
        if (!v["overrides"].is_array()) wo.fail("expected an array");
        for (std::size_t k = 0; k < v["overrides"].size(); ++k) {
          const json& o = v["overrides"][k];
          const Where wk = wo.at(k);
          check_keys(o, wk, {"material", "stack", "set", "renormalise"});
          if (!o.contains("material")) wk.fail("missing \"material\" (a glTF material name)");
          MaterialOverride ov;
          ov.material = get_string(o["material"], wk.key("material"));
          if (o.contains("stack")) ov.stack = get_file(o["stack"], wk.key("stack"), directory);
          if (o.contains("set")) {
            if (!o["set"].is_object()) wk.key("set").fail("expected an object {stack path: value}");
            for (auto it = o["set"].begin(); it != o["set"].end(); ++it) {
              batch_detail::stack_path_steps(it.key(), wk.key("set"));
              check_setting_value(it.value(), wk.key("set").key(it.key()));
              ov.set.push_back({it.key(), it.value()});
            }
          }
          if (o.contains("renormalise")) {
            if (!o["renormalise"].is_boolean()) wk.key("renormalise").fail("expected true or false");
            ov.renormalise = o["renormalise"].get<bool>();
          }
          for (const MaterialOverride& other : variant.overrides)
            if (other.material == ov.material) wk.key("material").fail("material '" + ov.material + "' is overridden twice in this variant");
          // Every scene must have the material and a stack for it.
          for (std::size_t si = 0; si < m.scenes.size(); ++si) {
            if (!scene_materials[si].count(ov.material))
              wk.key("material").fail("'" + ov.material + "' is not a material of scene '" + m.scenes[si].name + "' (materials: " +
                                      join(scene_materials[si]) + ")");
            // The stack a job renders such a material with is the file (as on the command line,
            // where --stack wins over the map): a variant could not change it.
            if (m.scenes[si].stack_assigned(ov.material))
              wk.key("material").fail("'" + ov.material + "' is assigned a stack by \"" + stack_key() + "\" in scene '" +
                                      m.scenes[si].name + "': a variant cannot override it (map it in the scene's \"materials\" instead)");
            if (ov.stack.empty() && !m.scenes[si].materials.count(ov.material))
              wk.fail("no \"stack\" given and scene '" + m.scenes[si].name + "' maps no stack to '" + ov.material + "'");
          }
          variant.overrides.push_back(std::move(ov));
        }
      }
      for (const VariantSpec& other : m.variants)
        if (other.name == variant.name) w.key("name").fail("duplicate variant name '" + variant.name + "'");
      m.variants.push_back(std::move(variant));
    }
  } else {
    m.variants.push_back({"base", {}});
  }

  if (j.contains("lighting")) {
    const Where wl = root.key("lighting");
    if (!j["lighting"].is_array() || j["lighting"].empty()) wl.fail("expected a non-empty array of lighting set-ups");
    for (std::size_t i = 0; i < j["lighting"].size(); ++i) {
      const json& l = j["lighting"][i];
      const Where w = wl.at(i);
      check_keys(l, w, {"name", "env", "camera"});
      if (!l.contains("name")) w.fail("missing \"name\"");
      LightingSpec lighting;
      lighting.name = get_name(l["name"], w.key("name"));
      if (l.contains("env")) parse_env(l["env"], w.key("env"), directory, lighting);
      if (l.contains("camera")) {
        lighting.camera = get_string(l["camera"], w.key("camera"));
        for (std::size_t si = 0; si < m.scenes.size(); ++si)
          if (!scene_cameras[si].count(lighting.camera))
            w.key("camera").fail("scene '" + m.scenes[si].name + "' has no camera '" + lighting.camera + "' (cameras: " + join(scene_cameras[si]) + ")");
      }
      for (const LightingSpec& other : m.lighting)
        if (other.name == lighting.name) w.key("name").fail("duplicate lighting name '" + lighting.name + "'");
      m.lighting.push_back(std::move(lighting));
    }
  } else {
    m.lighting.push_back({"default", "", false, ""});
  }

  if (j.contains("modes")) {
    const Where w = root.key("modes");
    const json modes = j["modes"].is_array() ? j["modes"] : json::array({j["modes"]});
    if (modes.empty()) w.fail("expected a non-empty list of modes");
    for (std::size_t i = 0; i < modes.size(); ++i) {
      const Where wi = j["modes"].is_array() ? w.at(i) : w;
      ModeSpec mode = parse_mode(modes[i], wi);
      for (const ModeSpec& other : m.modes) {
        if (other.name == mode.name) (modes[i].is_object() && modes[i].contains("name") ? wi.key("name") : wi).fail("duplicate mode name '" + mode.name + "'");
        // Rendering is deterministic: the same settings twice would be the same image twice.
        if (other.subsurface == mode.subsurface)
          wi.fail("mode '" + mode.name + "' renders the same as mode '" + other.name + "'");
      }
      m.modes.push_back(std::move(mode));
    }
  } else {
    m.modes.push_back({subsurface_mode_name(SubsurfaceMode::RandomWalk), SubsurfaceChoice::fixed(SubsurfaceMode::RandomWalk)});
  }

  if (!j.contains("spp")) root.fail("missing \"spp\" (a number or a list of samples per pixel)");
  {
    const Where w = root.key("spp");
    const json spp = j["spp"].is_array() ? j["spp"] : json::array({j["spp"]});
    if (spp.empty()) w.fail("expected a non-empty list");
    for (std::size_t i = 0; i < spp.size(); ++i) {
      const int n = static_cast<int>(get_integer(spp[i], j["spp"].is_array() ? w.at(i) : w, 1, 1 << 20));
      if (std::find(m.spp.begin(), m.spp.end(), n) != m.spp.end()) w.at(i).fail("duplicate spp " + std::to_string(n));
      m.spp.push_back(n);
    }
  }

  if (j.contains("comparisons")) {
    const Where wc = root.key("comparisons");
    if (!j["comparisons"].is_array()) wc.fail("expected an array");
    for (std::size_t i = 0; i < j["comparisons"].size(); ++i) {
      const json& c = j["comparisons"][i];
      const Where w = wc.at(i);
      check_keys(c, w, {"name", "reference", "test"});
      for (const char* k : {"name", "reference", "test"})
        if (!c.contains(k)) w.fail(std::string("missing \"") + k + "\"");
      ComparisonSpec cmp;
      cmp.name = get_name(c["name"], w.key("name"));
      cmp.reference = parse_selector(c["reference"], w.key("reference"), m);
      cmp.test = parse_selector(c["test"], w.key("test"), m);
      for (const ComparisonSpec& other : m.comparisons)
        if (other.name == cmp.name) w.key("name").fail("duplicate comparison name '" + cmp.name + "'");
      m.comparisons.push_back(std::move(cmp));
    }
  }

  if (j.contains("contact_sheet")) {
    const Where w = root.key("contact_sheet");
    const json& c = j["contact_sheet"];
    check_keys(c, w, {"columns", "thumbnail_width", "diff_range", "diff_smooth", "exposure", "tone_curve"});
    if (c.contains("columns")) m.contact_sheet.columns = static_cast<int>(get_integer(c["columns"], w.key("columns"), 1, 64));
    if (c.contains("thumbnail_width"))
      m.contact_sheet.thumbnail_width = static_cast<int>(get_integer(c["thumbnail_width"], w.key("thumbnail_width"), 16, 2048));
    if (c.contains("diff_range")) {
      const json& r = c["diff_range"];
      if (!r.is_number() || !(r.get<double>() > 0.0) || !std::isfinite(r.get<double>()))
        w.key("diff_range").fail("expected a positive number, got " + r.dump());
      m.contact_sheet.diff_range = r.get<double>();
    }
    if (c.contains("diff_smooth")) {
      const json& r = c["diff_smooth"];
      if (!r.is_number() || !(r.get<double>() >= 0.0 && r.get<double>() <= kMaxSmoothSigma))
        w.key("diff_smooth").fail("expected a Gaussian sigma in pixels in [0, " + std::to_string(static_cast<int>(kMaxSmoothSigma)) +
                                   "], got " + r.dump());
      m.contact_sheet.diff_smooth = r.get<double>();
    }
    if (c.contains("exposure")) {
      const json& e = c["exposure"];
      if (!e.is_number() || !(std::abs(e.get<double>()) <= 20.0))
        w.key("exposure").fail("expected a number of stops in [-20, 20], got " + e.dump());
      m.contact_sheet.tone_map.exposure = e.get<double>();
    }
    if (c.contains("tone_curve")) {
      const json& t = c["tone_curve"];
      if (!t.is_string() || !parse_tone_curve(t.get<std::string>(), &m.contact_sheet.tone_map.curve))
        w.key("tone_curve").fail("expected \"filmic\" or \"clamp\", got " + t.dump());
    }
  }
  return m;
}

Manifest load_manifest(const std::string& path) {
  // Read whole, so that the nesting depth is checked before parsing (materials/stack/json_limits.h):
  // no manifest nests more than a few levels, and deeper JSON would overflow the stack of the
  // recursive walks over the document.
  std::string text;
  if (const std::string why = read_text_file(path, &text); !why.empty())
    throw ManifestError(path + ": cannot read the manifest: " + why);
  json j;
  const std::string why = parse_json_text(text, &j);
  if (!why.empty()) throw ManifestError(path + ": " + why);
  const std::string directory = fs::absolute(fs::path(path)).parent_path().lexically_normal().string();
  return parse_manifest(j, path, directory);
}

}  // namespace lamina
