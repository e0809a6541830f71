// The subcommands of `lamina`. Each takes the arguments after the program name (argv[0] is the
// subcommand's name), prints its own --help, and returns the process exit code: 0 on success,
// non-zero with a one-line error on stderr on bad input.
#pragma once

int run_brdf(int argc, char** argv);
