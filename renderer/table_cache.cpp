// The table cache (layout and key in table_cache.h).
#include "renderer/table_cache.h"

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

#include "renderer/content_hash.h"

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

}  // namespace

std::string executable_build_id() {
  static const std::string id = [] {
    std::string s;
    dl_iterate_phdr(find_build_id, &s);
    return s;
  }();
  return id;
}

std::string table_cache_key(const LayerStack& stack, const TableSettings& settings) {
  std::ostringstream text;
  text << std::hexfloat << "lamina table layout " << kLayoutVersion << "\nversion " << lamina_version() << "\nbuild "
       << executable_build_id() << "\nnodes " << settings.nodes << " grazing " << settings.grazing_cosine << " bins "
       << settings.bins_theta << ' ' << settings.bins_phi << " walks " << settings.walks_per_node << " seed "
       << settings.seed << '\n'
       << stack_fingerprint(stack);
  return content_hash(text.str());
}

TableCache::TableCache(std::string directory) : directory_(std::move(directory)) {
  std::error_code ec;
  fs::create_directories(directory_, ec);
  if (ec || !fs::is_directory(directory_))
    throw std::runtime_error(directory_ + ": cannot create the table cache directory" + (ec ? ": " + ec.message() : ""));
  if (::access(directory_.c_str(), W_OK) != 0) throw std::runtime_error(directory_ + ": the table cache directory is not writable");
}

std::string TableCache::path_of(const LayerStack& stack, const TableSettings& settings) const {
  return (fs::path(directory_) / (table_cache_key(stack, settings) + ".lamtable")).string();
}

std::optional<LayeredTable> TableCache::load(const LayerStack& stack, const TableSettings& settings) const {
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

void TableCache::store(const LayerStack& stack, const LayeredTable& table) const {
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
  // A temporary of this process, then an atomic rename over the final name.
  char host[256] = "host";
  ::gethostname(host, sizeof host - 1);
  const std::string tmp = path + ".tmp-" + host + "-" + std::to_string(::getpid());
  {
    std::ofstream f(tmp, std::ios::binary | std::ios::trunc);
    f.write(out.data(), static_cast<std::streamsize>(out.size()));
    f.close();
    if (!f) {
      std::error_code ec;
      fs::remove(tmp, ec);
      std::fprintf(stderr, "lamina: warning: %s: could not write the table cache entry\n", path.c_str());
      return;
    }
  }
  std::error_code ec;
  fs::rename(tmp, path, ec);
  if (ec) {
    fs::remove(tmp, ec);
    std::fprintf(stderr, "lamina: warning: %s: could not write the table cache entry: %s\n", path.c_str(), ec.message().c_str());
  }
}

}  // namespace lamina
