// lamina batch: the command line of renderer/batch/batch_run.h (docs/contracts.md, "lamina batch";
// the manifest schema and outputs are in docs/batch.md).
#include <cstdio>
#include <string>

#include <CLI/CLI.hpp>

#include "renderer/batch/batch_manifest.h"
#include "renderer/batch/batch_run.h"
#include "renderer/cli/commands.h"
#include "renderer/cli/options.h"

int run_batch(int argc, char** argv) {
  lamina::BatchOptions args;
  CLI::App app("Renders the jobs of a batch manifest (docs/batch.md), skipping complete ones, then writes the comparisons, "
               "a contact sheet and a summary CSV.",
               "lamina batch");
  app.add_option("manifest", args.manifest, "batch manifest (JSON)")->required();
  app.add_option("-o,--out", args.out, "output directory (default: <manifest name>-batch)");
  auto* shard = app.add_option("--shard", args.shard, "render only shard i of n (jobs whose index mod n is i); no comparisons");
  auto* fin = app.add_flag("--finalize", args.finalize, "render nothing: write comparisons, contact sheet and summary (after all shards)");
  shard->excludes(fin);
  app.add_flag("--list", args.list, "print the jobs (index, id, hash) of the batch or shard and exit");
  app.add_flag("--force", args.force, "re-render jobs even if their output is complete");
  app.add_option("--threads", args.threads, "render threads per job (0: all cores)")->check(lamina::cli::integer(0, 4096));
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    std::fprintf(stderr, "lamina batch: %s\n", lamina::cli::parse_error_line(e).c_str());
    return 2;
  }
  lamina::BatchLog log;
  // stdout is flushed after every line so that it interleaves with stderr (the render's
  // progress bar and warnings) in the order it happened.
  log.out = [](const std::string& line) {
    std::printf("%s\n", line.c_str());
    std::fflush(stdout);
  };
  log.err = [](const std::string& line) { std::fprintf(stderr, "%s\n", line.c_str()); };
  log.render = lamina::render_log();
  log.render_summary = [](const lamina::RenderRequest& request, const lamina::RenderResult& result) {
    lamina::print_render_summary(request, result);
    std::fflush(stdout);
  };
  log.render_error = [](const std::string& message) { std::fprintf(stderr, "lamina render: %s\n", message.c_str()); };
  try {
    return lamina::run_batch_manifest(args, log);
  } catch (const lamina::ManifestError& e) {
    std::fprintf(stderr, "lamina batch: %s\n", e.what());
    return 2;
  } catch (const lamina::BatchUsageError& e) {
    std::fprintf(stderr, "lamina batch: %s\n", e.what());
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "lamina batch: %s\n", e.what());
    return 1;
  }
}
