// Running a batch manifest (docs/batch.md): its jobs rendered in-process through render_job,
// skipped when complete, then the comparisons, previews, contact sheet and summary. The command
// line (renderer/cli/batch.cpp) parses the arguments and says where the lines go.
#pragma once

#include <functional>
#include <stdexcept>
#include <string>

#include "renderer/render/render_job.h"

namespace lamina {

struct BatchOptions {
  std::string manifest;
  std::string out;    // "" for "<manifest name>-batch"
  std::string shard;  // "i/n", or "" for all jobs
  bool finalize = false, list = false, force = false;
  int threads = 0;    // render threads per job (0: all cores)
};

// A failure of the batch (exit status 1): an unwritable output, jobs missing at --finalize.
struct BatchError : std::runtime_error {
  using std::runtime_error::runtime_error;
};
// Bad options (exit status 2), like a ManifestError.
struct BatchUsageError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// Where the lines go: `out` (stdout) and `err` (stderr) take whole lines, without the newline;
// `render` is the log of each job's render_job, `render_summary` its closing summary, and
// `render_error` the one-line error of a job that failed.
struct BatchLog {
  std::function<void(const std::string&)> out, err;
  RenderLog render;
  std::function<void(const RenderRequest&, const RenderResult&)> render_summary;
  std::function<void(const std::string&)> render_error;
};

// Returns the exit status (0, or 1 if a job failed). Throws ManifestError and BatchUsageError
// (status 2) and other std::exceptions (status 1), each with one line.
int run_batch_manifest(const BatchOptions& options, const BatchLog& log);

}  // namespace lamina
