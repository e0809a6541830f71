#include "materials/stack/json_keys.h"

#include <nlohmann/json.hpp>

namespace lamina {

const std::string* first_unknown_key(const nlohmann::json& object, std::initializer_list<const char*> allowed) {
  if (!object.is_object()) return nullptr;
  for (auto it = object.begin(); it != object.end(); ++it) {
    bool known = false;
    for (const char* a : allowed) known = known || it.key() == a;
    if (!known) return &it.key();
  }
  return nullptr;
}

std::string key_list(std::initializer_list<const char*> allowed) {
  std::string list;
  for (const char* a : allowed) list += (list.empty() ? "" : ", ") + std::string(a);
  return list;
}

}  // namespace lamina
