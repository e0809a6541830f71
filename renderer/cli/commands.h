// The subcommands of `lamina`, one file each in renderer/cli/; main.cpp dispatches to them.
// Each takes the arguments after the command name (argv[0] is "lamina <command>") and returns
// the process exit status.
#pragma once

int run_render(int argc, char** argv);
int run_compare(int argc, char** argv);
int run_brdf(int argc, char** argv);
