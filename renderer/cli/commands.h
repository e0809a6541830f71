// The subcommands of `lamina`. Each takes its own argv (argv[0] is the subcommand's name) and
// returns the process exit code; main.cpp only dispatches.
#pragma once

int run_render(int argc, char** argv);
