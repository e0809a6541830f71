// Limits on JSON input that are checked on the raw text, before any parser sees it.
//
// Why: nlohmann::json parses iteratively, but tinygltf turns the parsed document into its own
// Value tree recursively, and our own walks over JSON values (extras, bindings) recurse as
// well; 100,000 nested arrays overflow the stack (SIGSEGV) before any error can be reported.
// One scanner, here in the lowest layer, serves every JSON reader: glTF (.gltf and the JSON
// chunk of .glb, renderer/scene), material files (materials/stack/stack_file), material maps
// (renderer/layered/material_binding) and batch manifests (renderer/batch/manifest). Each reader reports the offset as its own one-line error naming
// the file: "FILE: JSON nested deeper than 512 levels (at byte N)".
#pragma once

#include <cstddef>
#include <optional>
#include <string>
#include <string_view>

#include <nlohmann/json.hpp>

namespace lamina {

// The deepest nesting of arrays and objects any Lamina JSON input may have. Material files and
// manifests nest fewer than 10 levels, a glTF's own structure about 8 (root, meshes, a mesh,
// primitives, a primitive, attributes, ...) and exporters' extras a few more; 512 leaves room
// for any real file while keeping every recursive walk of a parsed document far from the stack's
// end (each level costs a few hundred bytes of stack in tinygltf's conversion).
constexpr int kMaxJsonNesting = 512;

// The byte offset of the first '[' or '{' that opens a level deeper than `max_depth` (the
// outermost array or object is level 1), or nullopt if the text never nests that deep. Brackets
// inside strings do not count: a string runs from an unescaped '"' to the next unescaped '"',
// and a backslash escapes the character after it (RFC 8259 section 7), so "\\" ends with the
// escape and "\"" does not end the string. Only nesting is judged: text that is not valid JSON
// is left to the parser, which reports it with its own message.
std::optional<std::size_t> json_nesting_exceeds(std::string_view text, int max_depth = kMaxJsonNesting);

// The message every reader appends to "FILE: ": "JSON nested deeper than 512 levels (at byte N)".
std::string json_nesting_message(std::size_t offset, int max_depth = kMaxJsonNesting);

// Every JSON input's parse: the nesting check above, then nlohmann's parser, whose exceptions
// never reach the user as they are. Returns "" with the document in *out, or the reason for a
// one-line error: "JSON nested deeper than ...", "number '1e999' is too large for a double (at
// most 1.79769e+308)", or "malformed JSON: parse error at line L, column C: ..." (nlohmann's text
// without its "[json.exception...]" tag). *path (if given) receives the JSON path where the parser
// was when it failed ("settings.width", "layers[1].g"; "" for the document or where unknown), as
// the readers name paths in their other messages; without `path` the reason starts with it,
// "settings.width: number ...".
std::string parse_json_text(std::string_view text, nlohmann::json* out, std::string* path = nullptr);

}  // namespace lamina
