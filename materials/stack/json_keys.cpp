#include "materials/stack/json_keys.h"

#include <nlohmann/json.hpp>

namespace lamina {

namespace {

template <class Names>
const std::string* first_unknown(const nlohmann::json& object, const Names& allowed) {
  if (!object.is_object()) return nullptr;
  for (auto it = object.begin(); it != object.end(); ++it) {
    bool known = false;
    for (const char* a : allowed) known = known || it.key() == a;
    if (!known) return &it.key();
  }
  return nullptr;
}

template <class Names>
std::string list_of(const Names& allowed) {
  std::string list;
  for (const char* a : allowed) list += (list.empty() ? "" : ", ") + std::string(a);
  return list;
}

}  // namespace

const std::string* first_unknown_key(const nlohmann::json& object, std::initializer_list<const char*> allowed) {
  return first_unknown(object, allowed);
}

const std::string* first_unknown_key(const nlohmann::json& object, const std::vector<const char*>& allowed) {
  return first_unknown(object, allowed);
}

std::string key_list(std::initializer_list<const char*> allowed) { return list_of(allowed); }

std::string key_list(const std::vector<const char*>& allowed) { return list_of(allowed); }

}  // namespace lamina
