// What every fuzz target shares: the input as a file (the loaders under test read files, as
// `lamina` does), and the rule that tells a clean refusal from a finding.
//
// A clean refusal is any std::exception other than std::bad_alloc: `lamina` prints its what()
// as its one-line error. std::bad_alloc is a finding (an allocation sized by the input before it
// was validated: no file name in the message), and so is anything else that escapes, a crash, a
// sanitizer report, a timeout (-timeout) or a memory blow-up (-rss_limit_mb, -malloc_limit_mb).
#pragma once

#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <new>
#include <string>

namespace lamina::fuzz {

// Writes the input to a file of this process with the given extension (in /dev/shm when it
// exists, for speed) and returns its path; the same path for every input of a run.
inline std::string input_file(const std::uint8_t* data, std::size_t size, const char* extension) {
  static const std::string dir = access("/dev/shm", W_OK) == 0 ? "/dev/shm" : "/tmp";
  const std::string path = dir + "/lamina_fuzz_" + std::to_string(getpid()) + extension;
  std::FILE* f = std::fopen(path.c_str(), "wb");
  if (!f) std::abort();
  if (size > 0 && std::fwrite(data, 1, size, f) != size) std::abort();
  std::fclose(f);
  return path;
}

// Runs body(); a std::exception other than std::bad_alloc is a clean refusal.
template <class Body>
int refuse_cleanly(Body body) {
  try {
    body();
  } catch (const std::bad_alloc&) {
    std::fprintf(stderr, "finding: std::bad_alloc escaped (an allocation sized by unvalidated input)\n");
    std::abort();
  } catch (const std::exception&) {
  }
  return 0;
}

}  // namespace lamina::fuzz
