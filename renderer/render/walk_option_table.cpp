#include "renderer/render/walk_option_table.h"

#include "renderer/util/string_format.h"

namespace lamina {
namespace {

WalkOptionSpec switch_option(const char* flag, const char* key, const char* help, bool WalkOptions::*member,
                             const char* on_word, const char* off_word) {
  WalkOptionSpec s{flag, key, help, WalkOptionSpec::Kind::Switch};
  s.switch_member = member;
  s.on_word = on_word;
  s.off_word = off_word;
  return s;
}

WalkOptionSpec integer_option(const char* flag, const char* key, const char* help, int WalkOptions::*member, int lo,
                              int hi) {
  WalkOptionSpec s{flag, key, help, WalkOptionSpec::Kind::Integer};
  s.integer_member = member;
  s.lo = lo;
  s.hi = hi;
  return s;
}

WalkOptionSpec real_option(const char* flag, const char* key, const char* help, double WalkOptions::*member, double lo,
                           double hi, bool lo_open, bool hi_open) {
  WalkOptionSpec s{flag, key, help, WalkOptionSpec::Kind::Real};
  s.real_member = member;
  s.lo = lo;
  s.hi = hi;
  s.lo_open = lo_open;
  s.hi_open = hi_open;
  return s;
}

}  // namespace

const std::vector<WalkOptionSpec> kWalkOptionTable = {
    switch_option("--pool-samples", "lamina:pool_samples",
                  "random-walk: light samples of environment and emissive triangles per walk event (per-event) or one per "
                  "walk (shared)",
                  &WalkOptions::per_event_pool_samples, "per-event", "shared"),
    integer_option("--similarity-after", "lamina:similarity_after",
                   "random-walk, APPROXIMATE: after N exact collisions (0: none) continue in the similarity-transformed "
                   "medium (g -> 0, sigma_s (1 - g)); its bias is measured and printed (-1: exact)",
                   &WalkOptions::similarity_after, -1, 1000000),
    real_option("--guiding", "lamina:guiding",
                "random-walk: probability of Dwivedi's guided technique for flights in isotropic layers, in [0, 1) "
                "(unbiased; 0: off)",
                &WalkOptions::guiding, 0.0, 1.0, false, true),
    switch_option("--next-flight", "lamina:next_flight",
                  "random-walk: next-flight connections to delta lights (MIS over each flight's direction; unbiased)",
                  &WalkOptions::next_flight, "on", "off"),
};

std::string walk_option_text(const WalkOptionSpec& spec, const RandomWalkOptions& walk) {
  switch (spec.kind) {
    case WalkOptionSpec::Kind::Switch: return walk.*spec.switch_member ? spec.on_word : spec.off_word;
    case WalkOptionSpec::Kind::Integer: return std::to_string(walk.*spec.integer_member);
    case WalkOptionSpec::Kind::Real: return string_printf("%.17g", walk.*spec.real_member);
  }
  return "";
}

bool set_walk_switch(const WalkOptionSpec& spec, const std::string& word, RandomWalkOptions* walk) {
  if (spec.kind != WalkOptionSpec::Kind::Switch || (word != spec.on_word && word != spec.off_word)) return false;
  walk->*spec.switch_member = word == spec.on_word;
  return true;
}

std::vector<std::string> walk_option_arguments(const RandomWalkOptions& walk) {
  const RandomWalkOptions defaults;  // the renderer's preset
  std::vector<std::string> args;
  for (const WalkOptionSpec& spec : kWalkOptionTable) {
    const std::string value = walk_option_text(spec, walk);
    if (value != walk_option_text(spec, defaults)) args.insert(args.end(), {spec.flag, value});
  }
  return args;
}

}  // namespace lamina
