// The walk cache (layout and keys in walk_cache.h).
#include "renderer/layered/walk_cache.h"

#include <link.h>
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <vector>

#include <nlohmann/json.hpp>

#include "renderer/util/atomic_file.h"
#include "renderer/util/content_hash.h"
#include "renderer/util/version.h"

namespace lamina {
namespace {

namespace fs = std::filesystem;

// Bump when the file layout or the meaning of a table's numbers changes.
constexpr std::uint32_t kLayoutVersion = 1;
constexpr char kMagic[8] = {'L', 'A', 'M', 'T', 'A', 'B', 'L', 'E'};

// The GNU build id note of the main program (the first object dl_iterate_phdr reports).
int find_build_id(struct dl_phdr_info* info, size_t, void* data) {
  auto* out = static_cast<std::string*>(data);
  for (int i = 0; i < info->dlpi_phnum; ++i) {
    const ElfW(Phdr)& ph = info->dlpi_phdr[i];
    if (ph.p_type != PT_NOTE) continue;
    const char* p = reinterpret_cast<const char*>(info->dlpi_addr + ph.p_vaddr);
    const char* end = p + ph.p_memsz;
    while (p + sizeof(ElfW(Nhdr)) <= end) {
      const auto* note = reinterpret_cast<const ElfW(Nhdr)*>(p);
      const char* name = p + sizeof(ElfW(Nhdr));
      const char* desc = name + ((note->n_namesz + 3) & ~3u);
      if (desc + note->n_descsz > end) break;
      if (note->n_type == NT_GNU_BUILD_ID && note->n_namesz == 4 && std::memcmp(name, "GNU", 4) == 0) {
        static const char* hex = "0123456789abcdef";
        for (unsigned k = 0; k < note->n_descsz; ++k) {
          const unsigned char c = static_cast<unsigned char>(desc[k]);
          out->push_back(hex[c >> 4]);
          out->push_back(hex[c & 15]);
        }
        return 1;
      }
      p = desc + ((note->n_descsz + 3) & ~3u);
    }
  }
  return 1;  // only the main program
}

template <class T>
void put(std::string& out, const T& v) {
  out.append(reinterpret_cast<const char*>(&v), sizeof v);
}
template <class T>
bool get(const std::string& in, std::size_t* at, T* v) {
  if (*at + sizeof(T) > in.size()) return false;
  std::memcpy(v, in.data() + *at, sizeof(T));
  *at += sizeof(T);
  return true;
}
template <class T>
void put_vector(std::string& out, const std::vector<T>& v) {
  put(out, static_cast<std::uint64_t>(v.size()));
  out.append(reinterpret_cast<const char*>(v.data()), v.size() * sizeof(T));
}
template <class T>
bool get_vector(const std::string& in, std::size_t* at, std::size_t expected, std::vector<T>* v) {
  std::uint64_t n = 0;
  if (!get(in, at, &n) || n != expected || *at + n * sizeof(T) > in.size()) return false;
  v->resize(n);
  std::memcpy(v->data(), in.data() + *at, n * sizeof(T));
  *at += n * sizeof(T);
  return true;
}

// `bytes` into `path` atomically (creating the directory); a failure is a warning naming the
// file: the render has its result either way.
void write_atomically(const std::string& path, const std::string& bytes, const char* what) {
  std::error_code ec;
  fs::create_directories(fs::path(path).parent_path(), ec);
  try {
    write_file_atomically(path, bytes);
  } catch (const AtomicWriteError& e) {
    std::fprintf(stderr, "lamina: warning: %s: could not write the %s cache entry: %s\n", path.c_str(), what, e.reason.c_str());
  }
}

// Record keys are file names: 32 hex digits only.
bool is_key(const std::string& key) {
  return key.size() == 32 && key.find_first_not_of("0123456789abcdef") == std::string::npos;
}

}  // namespace

std::string executable_build_id() {
  static const std::string id = [] {
    std::string s;
    dl_iterate_phdr(find_build_id, &s);
    return s;
  }();
  return id;
}

std::string walk_cache_key(const std::string& what) {
  std::ostringstream text;
  text << "lamina walk cache layout " << kLayoutVersion << "\nversion " << lamina_version() << "\nbuild "
       << executable_build_id() << '\n'
       << what;
  return content_hash(text.str());
}

std::string table_cache_key(const LayerStack& stack, const TableSettings& settings) {
  std::ostringstream text;
  text << std::hexfloat << "table\nnodes " << settings.nodes << " grazing " << settings.grazing_cosine << " bins "
       << settings.bins_theta << ' ' << settings.bins_phi << " walks " << settings.walks_per_node << " seed "
       << settings.seed << '\n';
  // Adding-doubling tables are keyed apart (the walk's keys stay as they were).
  if (settings.method == TableSettings::Method::AddingDoubling)
    text << "adding-doubling " << settings.quadrature_points << '\n';
  text << stack_fingerprint(stack);
  return walk_cache_key(text.str());
}

WalkCache::WalkCache(std::string directory) : directory_(std::move(directory)) {
  std::error_code ec;
  fs::create_directories(directory_, ec);
  if (ec || !fs::is_directory(directory_))
    throw std::runtime_error(directory_ + ": cannot create the cache directory" + (ec ? ": " + ec.message() : ""));
  if (::access(directory_.c_str(), W_OK) != 0) throw std::runtime_error(directory_ + ": the cache directory is not writable");
}

std::string WalkCache::path_of(const LayerStack& stack, const TableSettings& settings) const {
  return (fs::path(directory_) / "tables" / (table_cache_key(stack, settings) + ".lamtable")).string();
}

std::optional<LayeredTable> WalkCache::load(const LayerStack& stack, const TableSettings& settings) const {
  const std::string path = path_of(stack, settings);
  std::ifstream file(path, std::ios::binary);
  if (!file) return std::nullopt;  // a plain miss
  std::stringstream buffer;
  buffer << file.rdbuf();
  const std::string in = buffer.str();
  LayeredTable t;
  t.stack = &stack;
  t.settings = settings;
  std::size_t at = 0;
  char magic[8];
  std::uint32_t version = 0;
  char key[32];
  std::int32_t nodes = 0, bins_theta = 0, bins_phi = 0;
  bool ok = get(in, &at, &magic) && std::memcmp(magic, kMagic, 8) == 0 && get(in, &at, &version) && version == kLayoutVersion &&
            get(in, &at, &key) && std::memcmp(key, table_cache_key(stack, settings).data(), 32) == 0 && get(in, &at, &nodes) &&
            get(in, &at, &bins_theta) && get(in, &at, &bins_phi) && nodes == settings.nodes &&
            bins_theta == settings.bins_theta && bins_phi == settings.bins_phi;
  if (ok) {
    const std::size_t B = static_cast<std::size_t>(t.bins());
    ok = get_vector(in, &at, nodes * B, &t.value) && get_vector(in, &at, nodes * B, &t.cdf) &&
         get_vector(in, &at, static_cast<std::size_t>(nodes), &t.power) && at == in.size();
  }
  if (!ok) {
    std::fprintf(stderr, "lamina: warning: %s: not a valid table for this stack and build (truncated or stale); rebuilding it\n",
                 path.c_str());
    return std::nullopt;
  }
  t.build_seconds = 0.0;
  return t;
}

void WalkCache::store(const LayerStack& stack, const LayeredTable& table) const {
  const std::string path = path_of(stack, table.settings);
  std::string out;
  out.append(kMagic, 8);
  put(out, kLayoutVersion);
  out += table_cache_key(stack, table.settings);
  put(out, static_cast<std::int32_t>(table.settings.nodes));
  put(out, static_cast<std::int32_t>(table.settings.bins_theta));
  put(out, static_cast<std::int32_t>(table.settings.bins_phi));
  put_vector(out, table.value);
  put_vector(out, table.cdf);
  put_vector(out, table.power);
  write_atomically(path, out, "table");
}


std::optional<std::string> WalkCache::load_record(const std::string& kind, const std::string& key) const {
  if (!is_key(key)) return std::nullopt;
  std::ifstream file(fs::path(directory_) / kind / (key + ".json"), std::ios::binary);
  if (!file) return std::nullopt;
  std::stringstream buffer;
  buffer << file.rdbuf();
  return buffer.str();
}

void WalkCache::store_record(const std::string& kind, const std::string& key, const std::string& text) const {
  if (!is_key(key)) return;
  write_atomically((fs::path(directory_) / kind / (key + ".json")).string(), text, kind.c_str());
}

namespace {

std::string albedo_key(const LayeredMaterial& m) {
  std::ostringstream what;
  what << "lambert albedo\nwalks " << m.albedo_walks() << " seed " << LayeredMaterial::kAlbedoSeed << '\n';
  // A rough top's albedo is adding-doubling's now, no longer its walks': not the old records.
  if (m.base_stack().rough_top()) what << "rough top by adding-doubling\n";
  what << stack_fingerprint(m.base_stack());
  return walk_cache_key(what.str());
}

}  // namespace

bool load_lambert_albedo(const WalkCache& cache, const LayeredMaterial& material) {
  const std::string key = albedo_key(material);
  const std::optional<std::string> text = cache.load_record("albedo", key);
  if (!text) return false;
  try {
    const nlohmann::json j = nlohmann::json::parse(*text);
    Spectrum a, se;
    for (int c = 0; c < kChannels; ++c) {
      a[c] = j.at("albedo").at(c).get<double>();
      se[c] = j.at("stderr").at(c).get<double>();
    }
    return material.preset_lambert_albedo(a, se);
  } catch (const std::exception&) {
    std::fprintf(stderr, "lamina: warning: %s/albedo/%s.json: not a valid albedo record; recomputing it\n",
                 cache.directory().c_str(), key.c_str());
    return false;
  }
}

void store_lambert_albedo(const WalkCache& cache, const LayeredMaterial& material) {
  if (!material.lambert_albedo_computed()) return;
  const Spectrum& a = material.lambert_albedo();
  const Spectrum& se = material.lambert_albedo_stderr();
  // nlohmann writes doubles in their shortest round-trip form: the values come back exactly.
  const nlohmann::json j = {{"albedo", {a[0], a[1], a[2]}}, {"stderr", {se[0], se[1], se[2]}}};
  cache.store_record("albedo", albedo_key(material), j.dump() + "\n");
}

}  // namespace lamina
