// Content hashes for caches and job records: what changed, not who changed it.
#pragma once

#include <string>

namespace lamina {

// A 128-bit FNV-1a hash as 32 hex digits: detects changes, not tampering.
std::string content_hash(const std::string& bytes);

}  // namespace lamina
