// Writing a file so that a reader sees either the previous file or the complete new one, never a
// part of it: the bytes go to a temporary beside the file (same directory, so rename(2) never
// crosses a file system and is atomic on POSIX), are flushed to the disk, and the temporary is
// renamed over the file. Every writer of outputs and cache entries uses this one.
//
// Temporaries are named "<file>.tmp-<host>-<pid>-<n>": unique per host, process and call, so
// concurrent writers (batch shards on a shared file system) never collide, and a process that
// finds one of its own name after a crash knows it is stale (lamina batch removes them).
#pragma once

#include <stdexcept>
#include <string>

namespace lamina {

// what(): "cannot write 'PATH': REASON".
struct AtomicWriteError : std::runtime_error {
  AtomicWriteError(const std::string& path, const std::string& reason);
  std::string path, reason;
};

// A fresh temporary name beside `path` (see above).
std::string temporary_path(const std::string& path);

// Makes the written temporary `tmp` the file `path`: fsync, then rename. On failure removes
// `tmp` and throws AtomicWriteError; `path` is then untouched.
void commit_temporary(const std::string& tmp, const std::string& path);

// Writes `bytes` to `path` atomically. Throws AtomicWriteError (and leaves `path` untouched).
void write_file_atomically(const std::string& path, const std::string& bytes);

}  // namespace lamina
