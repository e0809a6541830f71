// The rules that combine a render's options (which option needs which mode or output), checked
// once here for every caller: `lamina render` (which prints the message as a usage error),
// `lamina batch` and the Python package (a ValueError) get the same one-line message, naming the
// options by their `lamina render` flags. Each option's own range is its parser's business.
#pragma once

#include <stdexcept>

#include <string>
#include <vector>

#include "renderer/layered/layered_material.h"
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

// The rule that needs the scene's materials, checked once they are loaded: walk-built tables
// (`--table-method walk`) of a stack with energy-conserving rough interfaces would hold only the
// light that scattered in it (the walk's unscattered light through rough facets is not
// tabulated), so such a request is refused, naming the material; the default adding-doubling
// tables take these stacks. The walk that table building falls back to on its own (for lobes
// adding-doubling cannot resolve) is not a request and is not affected.
void check_table_method(const RenderRequest& request, const LayeredBindings& bindings, const std::vector<std::string>& material_names);

}  // namespace lamina
