#include "materials/stack/text_file.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

namespace lamina {
namespace {

std::string reason_of(int error) {
  switch (error) {
    case ENOENT: return "does not exist";
    case ENOTDIR: return "does not exist (a part of the path is not a directory)";
    case EACCES:
    case EPERM: return "permission denied";
    case EISDIR: return "is a directory, not a file";
    default: return std::strerror(error);
  }
}

// Opens `path` for reading and checks that it is a regular file; -1 with *why set otherwise.
int open_regular(const std::string& path, std::string* why) {
  if (path.empty()) {
    *why = "does not exist (an empty path)";
    return -1;
  }
  // O_NONBLOCK: a FIFO is refused below rather than waited on for a writer.
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC | O_NONBLOCK);
  if (fd < 0) {
    *why = reason_of(errno);
    return -1;
  }
  struct stat st {};
  if (::fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
    *why = S_ISDIR(st.st_mode) ? "is a directory, not a file" : "is not a regular file";
    ::close(fd);
    return -1;
  }
  return fd;
}

}  // namespace

std::string file_unreadable_reason(const std::string& path) {
  std::string why;
  const int fd = open_regular(path, &why);
  if (fd >= 0) ::close(fd);
  return why;
}

std::string read_text_file(const std::string& path, std::string* text) {
  std::string why;
  const int fd = open_regular(path, &why);
  if (fd < 0) return why;
  text->clear();
  char buf[65536];
  for (;;) {
    const ssize_t n = ::read(fd, buf, sizeof buf);
    if (n == 0) break;
    if (n < 0) {
      if (errno == EINTR) continue;
      why = std::string("read error: ") + std::strerror(errno);
      break;
    }
    text->append(buf, static_cast<std::size_t>(n));
  }
  ::close(fd);
  return why;
}

}  // namespace lamina
