#include "renderer/util/paths.h"

#include <filesystem>

namespace lamina {

std::string resolve_relative_to(const std::string& path, const std::string& naming_file) {
  namespace fs = std::filesystem;
  const fs::path p(path);
  if (p.is_absolute()) return p.string();
  return (fs::path(naming_file).parent_path() / p).lexically_normal().string();
}

bool same_file(const std::string& a, const std::string& b) {
  if (a.empty() || b.empty()) return false;
  std::error_code ec;
  return std::filesystem::equivalent(a, b, ec);
}

}  // namespace lamina
