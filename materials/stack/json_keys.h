// Unknown keys in a JSON object. Every reader of Lamina's JSON files (material files here;
// material maps, stack bindings and batch manifests in renderer/) rejects them, so that a
// misspelt key ("sigma_S", "frekles") is an error and never silently a default. Each reader
// words its own message (with its own JSON path); the check is this one.
#pragma once

#include <initializer_list>
#include <string>
#include <vector>

#include <nlohmann/json_fwd.hpp>

namespace lamina {

// The first key of `object` (in the object's order) that is not in `allowed`, or nullptr (also
// when `object` is not an object). The pointer refers into `object`.
const std::string* first_unknown_key(const nlohmann::json& object, std::initializer_list<const char*> allowed);

// The allowed keys for a message: "stack, bind, freckles".
std::string key_list(std::initializer_list<const char*> allowed);

// The same for a list made at run time (keys declared once beside their data, e.g. leaf_keys()).
const std::string* first_unknown_key(const nlohmann::json& object, const std::vector<const char*>& allowed);
std::string key_list(const std::vector<const char*>& allowed);

}  // namespace lamina
