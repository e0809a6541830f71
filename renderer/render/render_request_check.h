// The rules that combine a render's options (which option needs which mode or output), checked
// once here for every caller: `lamina render` (which prints the message as a usage error),
// `lamina batch` and the Python package (a ValueError) get the same one-line message, naming the
// options by their `lamina render` flags. Each option's own range is its parser's business.
#pragma once

#include <stdexcept>

#include "renderer/render/render_job.h"

namespace lamina {

struct RenderRequestError : std::invalid_argument {
  using std::invalid_argument::invalid_argument;
};

// The limit on width x height x spp: it catches typos (an extra zero or three), not real renders.
inline constexpr double kMaxPathSamples = 1e12;

// Throws RenderRequestError on the first rule the request breaks. Options that would not act
// are refused, not recorded in the header as if they had: what the caller set is
// RenderRequest::given.
void check_render_request(const RenderRequest& request);

}  // namespace lamina
