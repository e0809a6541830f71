// lamina: one program, subcommands. main() only dispatches (docs/architecture.md, "cli/").
#include <cstdio>
#include <cstring>
#include <string>

#include "renderer/cli/commands.h"
#include "renderer/util/version.h"

namespace {

void print_usage(std::FILE* out) {
  std::fputs(
      "usage: lamina <command> [options]\n"
      "\n"
      "commands:\n"
      "  render   render a glTF 2.0 scene to a linear EXR\n"
      "  brdf     BRDF/BTDF of a layered material (first order or Monte Carlo)\n"
      "  compare  relative difference of two images\n"
      "  batch    render and compare the jobs of a manifest\n"
      "  denoise  Open Image Denoise on a rendered EXR (a new file; the raw render stays)\n"
      "  fit      fit parameters of a layered material to measured R and T\n"
      "\n"
      "'lamina <command> --help' describes a command.\n",
      out);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    print_usage(stderr);
    return 2;
  }
  const std::string command = argv[1];
  if (command == "--help" || command == "-h" || command == "help") {
    print_usage(stdout);
    return 0;
  }
  if (command == "brdf") return run_brdf(argc - 1, argv + 1);
  if (command == "--version") {
    std::printf("lamina %s (commit %s)\n", lamina::lamina_version(), lamina::lamina_commit());
    return 0;
  }
  // One line per command: it sees argv[1..] (its own name as argv[0]).
  if (command == "compare") return run_compare(argc - 1, argv + 1);
  if (command == "render") return run_render(argc - 1, argv + 1);
  if (command == "batch") return run_batch(argc - 1, argv + 1);
  if (command == "denoise") return run_denoise(argc - 1, argv + 1);
  if (command == "fit") return run_fit(argc - 1, argv + 1);
  std::fprintf(stderr, "lamina: unknown command '%s' (try 'lamina --help')\n", command.c_str());
  return 2;
}
