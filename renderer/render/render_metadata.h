// The EXR header of a render (docs/contracts.md, "lamina render"): every lamina:* key of a
// render job's output, each written once in a table over the typed request, its settings and
// its result, in the header's order. The walk options' keys come from their own table
// (walk_option_table.h).
#pragma once

#include <cstdint>
#include <vector>

#include "renderer/image/image_io.h"
#include "renderer/render/render_job.h"

namespace lamina {

// What the header's values are read from.
struct HeaderInputs {
  const RenderRequest& request;
  const RenderResult& result;  // its metadata is not read
};

// The keys that name the image (version, command, scene, camera): the previews' header is these
// and lamina:preview.
Metadata identity_metadata(const HeaderInputs& in);
// The whole header: the table's keys (lamina:spectral after the walk's in the spectral mode only:
// renderer/render/spectral_option.h), then lamina:crop (a crop), the similarity biases and the
// ignored maps (`prepared`: lamina:similarity_bias:*, lamina:ignored:*), lamina:tolerance and
// auto's choices (result.auto_choices: lamina:auto:*, lamina:auto_mode:*), and the request's
// extra metadata.
Metadata render_metadata(const HeaderInputs& in, const Metadata& similarity_bias, const Metadata& ignored);

}  // namespace lamina
