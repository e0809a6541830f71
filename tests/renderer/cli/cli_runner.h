// Runs the `lamina` program (LAMINA_EXE, set by lamina_cli_test) as a user would, through the
// shell, with stdout and stderr captured in files of a test's own directory.
#pragma once

#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

namespace lamina::test {

struct CliResult {
  int exit_code = -1;  // the program's exit status; 128 + signal number if a signal ended it
  std::string out, err;
};

// The whole file (empty if it cannot be read).
inline std::string slurp(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// `lamina ARGS` with stdout and stderr written to dir/stdout.txt and dir/stderr.txt (the
// directory must exist; each test uses its own, so tests may run in parallel).
inline CliResult run_lamina(const std::filesystem::path& dir, const std::string& args) {
  const std::filesystem::path out = dir / "stdout.txt", err = dir / "stderr.txt";
  const std::string cmd = std::string(LAMINA_EXE) + " " + args + " >'" + out.string() + "' 2>'" + err.string() + "'";
  const int status = std::system(cmd.c_str());
  CliResult r;
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  r.out = slurp(out);
  r.err = slurp(err);
  return r;
}

}  // namespace lamina::test
