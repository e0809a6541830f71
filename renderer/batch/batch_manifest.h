// Batch manifests (docs/batch.md): a JSON file listing scenes x material variants x lighting
// set-ups x modes x samples per pixel, and the comparisons to make between the resulting
// images. renderer/batch/ parses and validates a manifest and expands it into a deterministic
// list of render jobs, each with a stable id and a hash of everything that affects its image.
// Nothing there renders or writes files: renderer/cli/batch.cpp does.
//
// This header is the one to include; it gathers the parts: manifest.h (the schema, reading and
// validating a manifest) and jobs.h (job expansion, hashes, stack overrides, comparisons,
// shards). glTF files are read with renderer/scene/gltf_document.h, stack paths split with
// materials/stack/stack_parameters.h.
#pragma once

#include "renderer/batch/jobs.h"
#include "renderer/batch/manifest.h"
