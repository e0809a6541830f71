// Batch manifests: parsing, validation, job expansion and hashing (see batch_manifest.h).
#include "renderer/batch/batch_manifest.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>


namespace lamina {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

// Where a value sits in the manifest, for error messages: "m.json: variants[1].name".
struct Where {
  std::string file;
  std::string path;
  Where key(const std::string& k) const { return {file, path.empty() ? k : path + "." + k}; }
  Where at(std::size_t i) const { return {file, path + "[" + std::to_string(i) + "]"}; }
  [[noreturn]] void fail(const std::string& message) const {
    throw ManifestError(file + ": " + (path.empty() ? "" : path + ": ") + message);
  }
};

std::string type_name(const json& j) { return j.type_name(); }

void check_keys(const json& object, const Where& where, std::initializer_list<const char*> allowed) {
  if (!object.is_object()) where.fail("expected an object, got " + type_name(object));
  for (auto it = object.begin(); it != object.end(); ++it) {
    bool known = false;
    for (const char* k : allowed) known = known || it.key() == k;
    if (!known) {
      std::string list;
      for (const char* k : allowed) list += (list.empty() ? "" : ", ") + std::string(k);
      where.key(it.key()).fail("unknown key (expected one of: " + list + ")");
    }
  }
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

std::string read_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw ManifestError(path + ": cannot read the file");
  std::ostringstream s;
  s << in.rdbuf();
  if (in.bad()) throw ManifestError(path + ": read error");
  return s.str();
}

// The JSON part of a .gltf or .glb (glTF 2.0 spec, "GLB File Format Specification": a 12-byte
// header, then chunks of (length, type, data); the first chunk is the JSON one, type 'JSON').
json gltf_json(const std::string& path) {
  const std::string bytes = read_bytes(path);
  std::string text = bytes;
  if (bytes.size() >= 4 && bytes.compare(0, 4, "glTF") == 0) {
    if (bytes.size() < 20) throw ManifestError(path + ": truncated GLB header");
    std::uint32_t length = 0, type = 0;
    std::memcpy(&length, bytes.data() + 12, 4);  // GLB is little-endian, as is every host we build on
    std::memcpy(&type, bytes.data() + 16, 4);
    if (type != 0x4E4F534Au || 20ull + length > bytes.size()) throw ManifestError(path + ": GLB without a JSON chunk");
    text = bytes.substr(20, length);
  }
  try {
    json j = json::parse(text);
    if (!j.is_object()) throw ManifestError(path + ": not a glTF file (the JSON is not an object)");
    return j;
  } catch (const json::parse_error& e) {
    throw ManifestError(path + ": not a glTF file: " + e.what());
  }
}

std::set<std::string> gltf_material_names(const json& gltf) {
  std::set<std::string> names;
  if (gltf.contains("materials") && gltf["materials"].is_array())
    for (const json& m : gltf["materials"])
      if (m.contains("name") && m["name"].is_string()) names.insert(m["name"].get<std::string>());
  return names;
}

// Camera names `lamina render --camera` accepts: the camera's name, or its node's name.
std::set<std::string> gltf_camera_names(const json& gltf) {
  std::set<std::string> names;
  if (gltf.contains("cameras") && gltf["cameras"].is_array())
    for (const json& c : gltf["cameras"])
      if (c.contains("name") && c["name"].is_string()) names.insert(c["name"].get<std::string>());
  if (gltf.contains("nodes") && gltf["nodes"].is_array())
    for (const json& n : gltf["nodes"])
      if (n.contains("camera") && n.contains("name") && n["name"].is_string()) names.insert(n["name"].get<std::string>());
  return names;
}

std::string join(const std::set<std::string>& names) {
  std::string s;
  for (const std::string& n : names) s += (s.empty() ? "'" : ", '") + n + "'";
  return s.empty() ? "none" : s;
}

// "%20" and friends in glTF URIs (RFC 3986 percent-encoding).
std::string percent_decode(const std::string& uri) {
  std::string out;
  for (std::size_t i = 0; i < uri.size(); ++i) {
    if (uri[i] == '%' && i + 2 < uri.size() && std::isxdigit(static_cast<unsigned char>(uri[i + 1])) &&
        std::isxdigit(static_cast<unsigned char>(uri[i + 2]))) {
      out += static_cast<char>(std::strtol(uri.substr(i + 1, 2).c_str(), nullptr, 16));
      i += 2;
    } else {
      out += uri[i];
    }
  }
  return out;
}

// Parses "x" or "r,g,b" as finite numbers; false if the text is anything else.
bool is_number_list(const std::string& s) {
  int count = 0;
  std::size_t start = 0;
  while (true) {
    const std::size_t comma = s.find(',', start);
    const std::string part = s.substr(start, comma == std::string::npos ? std::string::npos : comma - start);
    char* end = nullptr;
    const double v = std::strtod(part.c_str(), &end);
    if (part.empty() || end != part.c_str() + part.size() || !std::isfinite(v)) return false;
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

const char* const kModes[] = {"random-walk", "first-order", "table", "lambert"};

bool is_fixed_mode(const std::string& mode) {
  return std::find_if(std::begin(kModes), std::end(kModes), [&](const char* k) { return mode == k; }) != std::end(kModes);
}

// One entry of "modes": a fixed mode as a string, or {"name", "subsurface", "tolerance"}.
ModeSpec parse_mode(const json& j, const Where& where) {
  const char* const auto_form = "{\"subsurface\": \"auto\", \"tolerance\": 0.05} (optional \"name\")";
  ModeSpec mode;
  if (j.is_string()) {
    mode.subsurface = j.get<std::string>();
    if (mode.subsurface == "auto") where.fail("mode \"auto\" needs a tolerance: write " + std::string(auto_form));
    if (!is_fixed_mode(mode.subsurface))
      where.fail("unknown mode '" + mode.subsurface + "' (expected random-walk, first-order, table, lambert or " + auto_form + ")");
    mode.name = mode.subsurface;
    return mode;
  }
  if (!j.is_object()) where.fail("expected a mode name or an object " + std::string(auto_form) + ", got " + type_name(j));
  check_keys(j, where, {"name", "subsurface", "tolerance"});
  if (!j.contains("subsurface")) where.fail("missing \"subsurface\" (random-walk, first-order, table, lambert or auto)");
  mode.subsurface = get_string(j["subsurface"], where.key("subsurface"));
  if (mode.subsurface != "auto" && !is_fixed_mode(mode.subsurface))
    where.key("subsurface").fail("unknown mode '" + mode.subsurface + "' (expected random-walk, first-order, table, lambert or auto)");
  if (mode.subsurface == "auto") {
    if (!j.contains("tolerance")) where.fail("\"subsurface\": \"auto\" needs a \"tolerance\" (a relative error in (0, 1], e.g. 0.05)");
    const json& t = j["tolerance"];
    // The largest predicted relative RMS error a material may have (renderer/layered/subsurface_auto.h):
    // the range `lamina render --tolerance` accepts, checked here so a bad manifest fails before
    // any job renders.
    if (!t.is_number() || !std::isfinite(t.get<double>()) || !(t.get<double>() > 0.0) || t.get<double>() > 1.0)
      where.key("tolerance").fail("expected a relative error in (0, 1], got " + t.dump());
    mode.tolerance = t.get<double>();
  } else if (j.contains("tolerance")) {
    where.key("tolerance").fail("a tolerance is only meaningful with \"subsurface\": \"auto\" (mode '" + mode.subsurface + "' is fixed)");
  }
  if (j.contains("name")) {
    mode.name = get_name(j["name"], where.key("name"));
  } else {
    // Shortest text that reads back as the same double: 0.05 -> "auto-0.05".
    mode.name = mode.subsurface == "auto" ? "auto-" + json(mode.tolerance).dump() : mode.subsurface;
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

// A stack path "layers[1].components[0].fraction" as a list of keys and indices.
struct PathStep {
  std::string key;  // empty for an index
  std::size_t index = 0;
};
std::vector<PathStep> parse_stack_path(const std::string& path, const Where& where) {
  std::vector<PathStep> steps;
  std::size_t i = 0;
  auto bad = [&] { where.fail("bad stack path '" + path + "' (expected e.g. layers[1].components[0].fraction)"); };
  while (i < path.size()) {
    if (path[i] == '[') {
      const std::size_t close = path.find(']', i);
      if (close == std::string::npos || close == i + 1) bad();
      const std::string digits = path.substr(i + 1, close - i - 1);
      if (digits.find_first_not_of("0123456789") != std::string::npos || digits.size() > 6) bad();
      steps.push_back({"", static_cast<std::size_t>(std::stoul(digits))});
      i = close + 1;
      if (i < path.size() && path[i] == '.') {
        ++i;
        if (i == path.size()) bad();
      }
    } else {
      std::size_t end = path.find_first_of(".[", i);
      if (end == std::string::npos) end = path.size();
      if (end == i) bad();
      steps.push_back({path.substr(i, end - i), 0});
      i = end;
      if (i < path.size() && path[i] == '.') {
        ++i;
        if (i == path.size()) bad();
      }
    }
  }
  if (steps.empty()) bad();
  return steps;
}

json* find_in_stack(json& stack, const std::vector<PathStep>& steps, const std::string& path, const Where& where) {
  json* node = &stack;
  std::string walked;
  for (const PathStep& s : steps) {
    if (s.key.empty()) {
      if (!node->is_array()) where.fail("'" + path + "': '" + walked + "' is not an array");
      if (s.index >= node->size())
        where.fail("'" + path + "': '" + walked + "' has " + std::to_string(node->size()) + " entries, no [" + std::to_string(s.index) + "]");
      node = &(*node)[s.index];
      walked += "[" + std::to_string(s.index) + "]";
    } else {
      walked += (walked.empty() ? "" : ".") + s.key;
      if (!node->is_object() || !node->contains(s.key)) where.fail("'" + path + "': the stack has no '" + walked + "'");
      node = &(*node)[s.key];
    }
  }
  return node;
}

void check_setting_value(const json& v, const Where& where) {
  auto finite = [](const json& x) { return x.is_number() && std::isfinite(x.get<double>()); };
  const bool ok = finite(v) || (v.is_string() && v.get<std::string>() == "inf") ||
                  (v.is_array() && v.size() == 3 && finite(v[0]) && finite(v[1]) && finite(v[2]));
  if (!ok) where.fail("expected a finite number, [r, g, b] or \"inf\", got " + v.dump());
}

}  // namespace

std::string file_hash(const std::string& path) { return content_hash(read_bytes(path)); }

std::string scene_hash(const std::string& path) {
  const json gltf = gltf_json(path);
  std::string all = "file " + file_hash(path) + "\n";
  const fs::path dir = fs::path(path).parent_path();
  for (const char* list : {"buffers", "images"}) {
    if (!gltf.contains(list) || !gltf[list].is_array()) continue;
    for (const json& item : gltf[list]) {
      if (!item.contains("uri") || !item["uri"].is_string()) continue;
      const std::string uri = item["uri"].get<std::string>();
      if (uri.rfind("data:", 0) == 0) continue;  // embedded: already in the file's bytes
      const std::string file = (dir / percent_decode(uri)).string();
      std::error_code ec;
      if (!fs::is_regular_file(file, ec)) throw ManifestError(path + ": " + list + " uri '" + uri + "' names no file");
      all += uri + " " + file_hash(file) + "\n";
    }
  }
  return content_hash(all);
}

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
    check_keys(s, w, {"width", "height", "seed", "max_depth"});
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
    check_keys(s, w, {"name", "file", "materials"});
    if (!s.contains("name")) w.fail("missing \"name\"");
    if (!s.contains("file")) w.fail("missing \"file\"");
    SceneSpec scene;
    scene.name = get_name(s["name"], w.key("name"));
    scene.file = get_file(s["file"], w.key("file"), directory);
    const std::string ext = fs::path(scene.file).extension().string();
    if (ext != ".gltf" && ext != ".glb") w.key("file").fail("'" + scene.file + "' is not a .gltf or .glb file");
    json gltf;
    try {
      gltf = gltf_json(scene.file);
    } catch (const ManifestError& e) {
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
              parse_stack_path(it.key(), wk.key("set"));
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
        if (other.subsurface == mode.subsurface && other.tolerance == mode.tolerance)
          wi.fail("mode '" + mode.name + "' renders the same as mode '" + other.name + "'");
      }
      m.modes.push_back(std::move(mode));
    }
  } else {
    m.modes.push_back({"random-walk", "random-walk", 0.0});
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
    check_keys(c, w, {"columns", "thumbnail_width", "diff_range"});
    if (c.contains("columns")) m.contact_sheet.columns = static_cast<int>(get_integer(c["columns"], w.key("columns"), 1, 64));
    if (c.contains("thumbnail_width"))
      m.contact_sheet.thumbnail_width = static_cast<int>(get_integer(c["thumbnail_width"], w.key("thumbnail_width"), 16, 2048));
    if (c.contains("diff_range")) {
      const json& r = c["diff_range"];
      if (!r.is_number() || !(r.get<double>() > 0.0) || !std::isfinite(r.get<double>()))
        w.key("diff_range").fail("expected a positive number, got " + r.dump());
      m.contact_sheet.diff_range = r.get<double>();
    }
  }
  return m;
}

Manifest load_manifest(const std::string& path) {
  std::error_code ec;
  if (fs::is_directory(path, ec)) throw ManifestError(path + ": is a directory, not a manifest");
  std::ifstream in(path);
  if (!in) throw ManifestError(path + ": cannot open the manifest");
  json j;
  try {
    j = json::parse(in);
  } catch (const json::parse_error& e) {
    throw ManifestError(path + ": not valid JSON: " + e.what());
  }
  const std::string directory = fs::absolute(fs::path(path)).parent_path().lexically_normal().string();
  return parse_manifest(j, path, directory);
}

void apply_stack_override(json& stack, const MaterialOverride& ov, const std::string& where_text) {
  const Where where{where_text, ""};
  // layer index -> the component indices whose fraction was set
  std::map<std::size_t, std::set<std::size_t>> set_fractions;
  for (const StackSetting& s : ov.set) {
    const std::vector<PathStep> steps = parse_stack_path(s.path, where);
    *find_in_stack(stack, steps, s.path, where) = s.value;
    if (steps.size() == 5 && steps[0].key == "layers" && steps[1].key.empty() && steps[2].key == "components" &&
        steps[3].key.empty() && steps[4].key == "fraction")
      set_fractions[steps[1].index].insert(steps[3].index);
  }
  if (!ov.renormalise) return;
  // Rescale the fractions not set so the layer's fractions sum to 1: with S the sum of the set
  // ones and O that of the others, each other fraction is multiplied by (1 - S) / O.
  for (const auto& [layer, set] : set_fractions) {
    json& components = stack["layers"][layer]["components"];
    double s = 0.0, o = 0.0;
    for (std::size_t c = 0; c < components.size(); ++c) {
      const json& f = components[c]["fraction"];
      if (!f.is_number()) where.fail("layers[" + std::to_string(layer) + "].components[" + std::to_string(c) + "].fraction is not a number");
      (set.count(c) ? s : o) += f.get<double>();
    }
    const std::string lw = "renormalise layers[" + std::to_string(layer) + "]: ";
    if (s < 0.0 || s > 1.0 + 1e-12) where.fail(lw + "the fractions set sum to " + json(s).dump() + ", more than 1");
    if (o <= 0.0) {
      if (std::abs(s - 1.0) > 1e-6) where.fail(lw + "no other component to rescale and the fractions set sum to " + json(s).dump());
      continue;
    }
    const double scale = (1.0 - s) / o;
    for (std::size_t c = 0; c < components.size(); ++c)
      if (!set.count(c)) components[c]["fraction"] = components[c]["fraction"].get<double>() * scale;
  }
}

std::vector<BatchJob> expand_jobs(const Manifest& m) {
  // Hash each input file once, however many jobs use it.
  std::map<std::string, std::string> scene_hashes, env_hashes;
  std::map<std::string, json> stacks;
  auto stack_json = [&](const std::string& file) -> const json& {
    auto it = stacks.find(file);
    if (it != stacks.end()) return it->second;
    json j;
    try {
      j = json::parse(read_bytes(file));
    } catch (const json::parse_error& e) {
      throw ManifestError(file + ": not valid JSON: " + e.what());
    }
    if (!j.is_object()) throw ManifestError(file + ": not a material file (expected a JSON object)");
    return stacks.emplace(file, std::move(j)).first->second;
  };

  std::vector<BatchJob> jobs;
  for (const SceneSpec& scene : m.scenes) {
    auto sh = scene_hashes.find(scene.file);
    if (sh == scene_hashes.end()) sh = scene_hashes.emplace(scene.file, scene_hash(scene.file)).first;
    for (std::size_t vi = 0; vi < m.variants.size(); ++vi) {
      const VariantSpec& variant = m.variants[vi];
      // The stacks of this scene under this variant, by glTF material name.
      std::map<std::string, MaterialBinding> bindings;
      for (const auto& [name, file] : scene.materials) bindings[name] = {name, stack_json(file), false};
      for (std::size_t oi = 0; oi < variant.overrides.size(); ++oi) {
        const MaterialOverride& ov = variant.overrides[oi];
        const std::string file = ov.stack.empty() ? scene.materials.at(ov.material) : ov.stack;
        MaterialBinding b{ov.material, stack_json(file), true};
        apply_stack_override(b.stack, ov,
                             m.path + ": variants[" + std::to_string(vi) + "].overrides[" + std::to_string(oi) + "] (" + file + ")");
        bindings[ov.material] = std::move(b);
      }
      json materials_desc = json::object();
      std::vector<MaterialBinding> binding_list;
      for (auto& [name, b] : bindings) {
        materials_desc[name] = content_hash(b.stack.dump());
        binding_list.push_back(b);
      }
      for (const LightingSpec& lighting : m.lighting) {
        json env_desc = lighting.env;
        if (lighting.env_is_file) {
          auto eh = env_hashes.find(lighting.env);
          if (eh == env_hashes.end()) eh = env_hashes.emplace(lighting.env, file_hash(lighting.env)).first;
          env_desc = json{{"file_hash", eh->second}};
        }
        for (const ModeSpec& mode : m.modes) {
          for (int spp : m.spp) {
            BatchJob job;
            job.index = jobs.size();
            job.scene = scene.name;
            job.variant = variant.name;
            job.lighting = lighting.name;
            job.mode = mode.name;
            job.subsurface = mode.subsurface;
            job.tolerance = mode.tolerance;
            job.spp = spp;
            job.id = scene.name + "__" + variant.name + "__" + lighting.name + "__" + mode.name + "__spp" + std::to_string(spp);
            job.scene_file = scene.file;
            job.materials = binding_list;
            job.env = lighting.env;
            job.camera = lighting.camera;
            // Everything that changes the pixels, and nothing else (not names, paths or the
            // thread count: rendering is deterministic for any thread count). "mode" is the
            // --subsurface argument, not the mode's name; the tolerance only exists for auto, so
            // the hashes of fixed-mode jobs are those of manifests written before auto existed.
            job.description = json{{"lamina_version", lamina_version()},
                                   {"scene_hash", sh->second},
                                   {"materials", materials_desc},
                                   {"env", env_desc},
                                   {"camera", lighting.camera},
                                   {"mode", mode.subsurface},
                                   {"spp", spp},
                                   {"seed", m.settings.seed},
                                   {"width", m.settings.width},
                                   {"height", m.settings.height},
                                   {"max_depth", m.settings.max_depth}};
            if (mode.subsurface == "auto") job.description["tolerance"] = mode.tolerance;
            job.hash = content_hash(job.description.dump());
            jobs.push_back(std::move(job));
          }
        }
      }
    }
  }
  return jobs;
}

std::vector<ComparisonPair> resolve_comparisons(const Manifest& m, const std::vector<BatchJob>& jobs) {
  auto key = [](const std::string& scene, const std::string& variant, const std::string& lighting, const std::string& mode, int spp) {
    return scene + "\n" + variant + "\n" + lighting + "\n" + mode + "\n" + std::to_string(spp);
  };
  std::map<std::string, std::size_t> by_axes;
  for (const BatchJob& j : jobs) by_axes[key(j.scene, j.variant, j.lighting, j.mode, j.spp)] = j.index;
  auto matches = [](const JobSelector& s, const BatchJob& j) {
    return (s.scene.empty() || s.scene == j.scene) && (s.variant.empty() || s.variant == j.variant) &&
           (s.lighting.empty() || s.lighting == j.lighting) && (s.mode.empty() || s.mode == j.mode) && (s.spp == 0 || s.spp == j.spp);
  };
  std::vector<ComparisonPair> pairs;
  for (std::size_t ci = 0; ci < m.comparisons.size(); ++ci) {
    const ComparisonSpec& c = m.comparisons[ci];
    const JobSelector& r = c.reference;
    std::size_t count = 0;
    for (const BatchJob& t : jobs) {
      if (!matches(c.test, t)) continue;
      const std::string k = key(r.scene.empty() ? t.scene : r.scene, r.variant.empty() ? t.variant : r.variant,
                                r.lighting.empty() ? t.lighting : r.lighting, r.mode.empty() ? t.mode : r.mode, r.spp == 0 ? t.spp : r.spp);
      const auto it = by_axes.find(k);
      if (it == by_axes.end())
        throw ManifestError(m.path + ": comparisons[" + std::to_string(ci) + "]: no reference job for test '" + t.id + "'");
      if (it->second == t.index) continue;
      pairs.push_back({c.name, it->second, t.index, c.name + "__" + t.id});
      ++count;
    }
    if (count == 0) throw ManifestError(m.path + ": comparisons[" + std::to_string(ci) + "]: '" + c.name + "' matches no pair of jobs");
  }
  return pairs;
}

bool in_shard(std::size_t job_index, int shard, int shard_count) {
  return shard_count <= 1 || job_index % static_cast<std::size_t>(shard_count) == static_cast<std::size_t>(shard);
}

std::pair<int, int> parse_shard(const std::string& text) {
  const std::size_t slash = text.find('/');
  auto number = [&](const std::string& s) {
    if (s.empty() || s.size() > 6 || s.find_first_not_of("0123456789") != std::string::npos)
      throw std::invalid_argument("--shard '" + text + "': expected i/n with 0 <= i < n, e.g. 0/4");
    return std::stoi(s);
  };
  if (slash == std::string::npos) throw std::invalid_argument("--shard '" + text + "': expected i/n with 0 <= i < n, e.g. 0/4");
  const int i = number(text.substr(0, slash)), n = number(text.substr(slash + 1));
  if (n < 1 || i >= n) throw std::invalid_argument("--shard '" + text + "': expected i/n with 0 <= i < n, e.g. 0/4");
  return {i, n};
}

}  // namespace lamina
