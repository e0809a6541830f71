#include "renderer/util/content_hash.h"

#include <cstdio>

namespace lamina {

// FNV-1a, 128-bit (Fowler, Noll, Vo; IETF draft-eastlake-fnv: offset basis and prime below).
std::string content_hash(const std::string& bytes) {
  __extension__ typedef unsigned __int128 u128;
  const u128 prime = (static_cast<u128>(1) << 88) + 0x13B;
  u128 h = (static_cast<u128>(0x6c62272e07bb0142ull) << 64) | 0x62b821756295c58dull;
  for (unsigned char c : bytes) {
    h ^= c;
    h *= prime;
  }
  char out[33];
  std::snprintf(out, sizeof out, "%016llx%016llx", static_cast<unsigned long long>(h >> 64),
                static_cast<unsigned long long>(h));
  return out;
}

}  // namespace lamina
