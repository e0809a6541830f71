// The subcommands of `lamina`, one file each in renderer/cli/; main.cpp dispatches to them.
// Each takes the arguments after the command name (argv[0] is "lamina <command>") and returns
// the process exit status.
#pragma once

int run_compare(int argc, char** argv);
int run_brdf(int argc, char** argv);
int run_render(int argc, char** argv);
int run_batch(int argc, char** argv);
int run_denoise(int argc, char** argv);
int run_fit(int argc, char** argv);

// Shared by render and batch (which renders its jobs in-process): the render's lines on stdout
// and stderr with the "lamina render: " prefix, and its closing summary.
namespace lamina {
struct RenderLog;
struct RenderRequest;
struct RenderResult;
RenderLog render_log();
void print_render_summary(const RenderRequest& request, const RenderResult& result);
}  // namespace lamina
