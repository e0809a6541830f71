// Reading a LayerStack from a material file (docs/contracts.md, "Material file").
//
// Every problem is reported as one line "SOURCE: JSON.PATH: reason", e.g.
//   skin.json: layers[1].components[0].fraction: fractions must sum to 1 (sum 0.9)
// so a user can find the bad value without reading code. Unknown keys are rejected at every
// level (a misspelt "sigma_s" must not silently become a default).
//
// Accepted beyond the contract's example (documented extensions, all optional):
//   - top level "name" (default: empty), "above_ior" (default 1.0), "below" (default {"ior": 1}).
//   - layer "name"; component "name".
#pragma once

#include <stdexcept>
#include <string>

#include "materials/stack/spectral_stack.h"
#include "materials/stack/stack.h"
#include "materials/stack/stack_parameters.h"

namespace lamina {

class StackFileError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Parses the JSON text of a material file. source_name (usually the file's path) prefixes every
// error message. Throws StackFileError.
LayerStack parse_stack_json(const std::string& text, const std::string& source_name);

// Reads and parses the file at path; errors name the path as given. Throws StackFileError.
LayerStack load_stack_file(const std::string& path);

// The same, keeping the description the stack was mixed from (each layer's components with
// their fractions), so that parameters can be changed per shading point (stack_parameters.h).
StackTemplate parse_stack_template_json(const std::string& text, const std::string& source_name);
StackTemplate load_stack_template(const std::string& path);

// A material file whose layers may be given by "chromophores" (docs/spectral.md). The functions
// above read such a layer in RGB (each channel the mean of its spectra,
// SkinChromophores::absorption_rgb); these keep the chromophores to evaluate per wavelength, and
// require the other layers and a Lambert substrate to be grey.
SpectralStack parse_spectral_stack_json(const std::string& text, const std::string& source_name);
SpectralStack load_spectral_stack(const std::string& path);
// The same file as a template whose layer descriptions keep their chromophores and leaf
// contents, for parameters bound to maps (stack_parameters.h; the spectral mode's leaf stacks).
StackTemplate load_spectral_stack_template(const std::string& path);

}  // namespace lamina
