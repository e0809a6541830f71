#include "renderer/util/python_plot.h"

#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <cstring>
#include <stdexcept>

extern char** environ;

namespace lamina {

#ifndef LAMINA_PYTHON_EXECUTABLE
#define LAMINA_PYTHON_EXECUTABLE "python3"
#endif
#ifndef LAMINA_PYTHON_PACKAGE_DIR
#define LAMINA_PYTHON_PACKAGE_DIR ""
#endif

void run_python_plot(const std::vector<std::string>& args) {
  const char* from_env = std::getenv("LAMINA_PYTHON");
  const std::string python = from_env && *from_env ? from_env : LAMINA_PYTHON_EXECUTABLE;
  std::vector<std::string> argv_text = {python, "-m", "lamina.plot"};
  argv_text.insert(argv_text.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (std::string& a : argv_text) argv.push_back(a.data());
  argv.push_back(nullptr);
  // The environment with the build tree's package first on PYTHONPATH.
  std::vector<std::string> env_text;
  std::string package_dir = LAMINA_PYTHON_PACKAGE_DIR, old_path;
  for (char** e = environ; *e; ++e) {
    if (std::strncmp(*e, "PYTHONPATH=", 11) == 0) old_path = *e + 11;
    else env_text.push_back(*e);
  }
  std::string path = package_dir;
  if (!old_path.empty()) path += (path.empty() ? "" : ":") + old_path;
  if (!path.empty()) env_text.push_back("PYTHONPATH=" + path);
  env_text.push_back("MPLBACKEND=Agg");
  std::vector<char*> envp;
  for (std::string& e : env_text) envp.push_back(e.data());
  envp.push_back(nullptr);
  pid_t pid = 0;
  if (posix_spawnp(&pid, python.c_str(), nullptr, nullptr, argv.data(), envp.data()) != 0)
    throw std::runtime_error("--plot: cannot run " + python + " (the plots need Python with the lamina package and "
                             "matplotlib: docs/python.md)");
  int status = 0;
  while (waitpid(pid, &status, 0) < 0) {
  }
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0)
    throw std::runtime_error("--plot: " + python + " -m lamina.plot failed (the plots need the lamina package and "
                             "matplotlib: docs/python.md)");
}

}  // namespace lamina
