// The walk options a user sets, each declared once: its `lamina render` flag (and help), its EXR
// header key (lamina:*, docs/contracts.md) and the argument a batch job's command line carries
// all come from its row of kWalkOptionTable. A new user-facing walk option is a field of the
// walk's options (materials/walk/walk_options.h) and one row here; its flag, header
// key and batch argument follow. Values absent from the table keep the renderer's preset
// (renderer_walk_options).
#pragma once

#include <string>
#include <vector>

#include "renderer/surfaces/random_walk_surface.h"

namespace lamina {

struct WalkOptionSpec {
  enum class Kind {
    Switch,   // a bool, written as one of two words (`on_word` for true)
    Integer,  // an int in [lo, hi]
    Real,     // a double in an interval whose ends may be open
  };
  const char* flag;     // `lamina render` option, and the batch job's argument: "--guiding"
  const char* exr_key;  // header key: "lamina:guiding"
  const char* help;     // `lamina render --help`
  Kind kind;
  bool WalkOptions::*switch_member = nullptr;
  const char* on_word = nullptr;
  const char* off_word = nullptr;
  int WalkOptions::*integer_member = nullptr;
  double WalkOptions::*real_member = nullptr;
  double lo = 0.0, hi = 0.0;  // Integer and Real: the accepted range
  bool lo_open = false, hi_open = false;  // Real: whether the ends are excluded
};

// In the order of the EXR header's keys.
extern const std::vector<WalkOptionSpec> kWalkOptionTable;

// The option's value as the header and the command line write it: the switch's word, the
// integer in decimal, the real as "%.17g" (which reads back as the same double).
std::string walk_option_text(const WalkOptionSpec& spec, const RandomWalkOptions& walk);
// A switch from its word; false (and no change) on another word.
bool set_walk_switch(const WalkOptionSpec& spec, const std::string& word, RandomWalkOptions* walk);
// The command-line arguments ("--flag", "value", ...) of the options whose value differs from
// the renderer's default: what reproduces `walk` on `lamina render`'s command line.
std::vector<std::string> walk_option_arguments(const RandomWalkOptions& walk);

}  // namespace lamina
