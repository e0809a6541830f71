// Paths named inside files: relative ones are relative to the file that names them (a glTF, a
// material map, a stack file), as glTF does for its URIs.
#pragma once

#include <string>

namespace lamina {

// `path` if absolute, else `path` resolved against the directory of `naming_file`, normalised
// lexically (no file system access).
std::string resolve_relative_to(const std::string& path, const std::string& naming_file);

// Whether `a` and `b` name the same existing file: the same path, another spelling of it, or a
// symbolic or hard link to it (the files themselves are compared). False if either is missing.
bool same_file(const std::string& a, const std::string& b);

}  // namespace lamina
