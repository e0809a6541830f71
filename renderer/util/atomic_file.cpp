#include "renderer/util/atomic_file.h"

#include <fcntl.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <fstream>

namespace lamina {

AtomicWriteError::AtomicWriteError(const std::string& p, const std::string& r)
    : std::runtime_error("cannot write '" + p + "': " + r), path(p), reason(r) {}

std::string temporary_path(const std::string& path) {
  static std::atomic<unsigned> counter{0};
  char host[256] = "host";
  ::gethostname(host, sizeof host - 1);
  host[sizeof host - 1] = '\0';
  return path + ".tmp-" + host + "-" + std::to_string(::getpid()) + "-" + std::to_string(counter++);
}

void commit_temporary(const std::string& tmp, const std::string& path) {
  // Flush the data to the disk before the rename makes it visible, so that after a crash the
  // name points either to the old file or to the complete new one.
  const int fd = ::open(tmp.c_str(), O_RDONLY);
  if (fd >= 0) {
    ::fsync(fd);
    ::close(fd);
  }
  if (std::rename(tmp.c_str(), path.c_str()) != 0) {
    const std::string reason = std::strerror(errno);
    std::remove(tmp.c_str());
    throw AtomicWriteError(path, reason);
  }
}

void write_file_atomically(const std::string& path, const std::string& bytes) {
  const std::string tmp = temporary_path(path);
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    if (!out) throw AtomicWriteError(path, std::strerror(errno));
    out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    out.close();
    if (!out) {
      std::remove(tmp.c_str());
      throw AtomicWriteError(path, "write failed");
    }
  }
  commit_temporary(tmp, path);
}

}  // namespace lamina
