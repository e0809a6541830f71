// `lamina render --subsurface auto --tolerance E`: per layered material, the cheapest shading
// model whose predicted error against the full random walk is within E.
//
// The prediction (no image is rendered): for each material's base stack (and its flipped stack
// if it transmits) and a few incidence cosines mu_j, the walk's BRDF/BTDF is tabulated once on
// a coarse grid of outgoing bins (materials/brdf_table: brdf_table_monte_carlo, with standard
// errors), together with the same binned quantities of the cheaper models:
//   lambert:     albedo/pi on the reflect side (the mode's albedo: lambert_albedo()), 0 on the
//                transmit side, and no delta parts;
//   first-order: brdf_table_first_order (the exact single-scattering bin averages) plus the
//                exact zeroth-order delta parts;
//   table:       the walk itself, so its error is the statistical error of a table of the size
//                the table mode builds (TableSettings) -- a conservative bound, since an image
//                pixel averages many bins.
// Metric: what reaches the image is L_o = int f L_i cos dw (+ the delta parts), so the quantity
// to compare is the cosine-weighted BSDF, i.e. each bin's power P(B) = value(B) Omega_proj(B)
// (fraction of the incident power leaving into B). The delta parts (R_specular + T_ballistic)
// are exact in first order and table and missing in lambert. The predicted error of a model m
// is the larger of
//   diffuse: e_m = sqrt( sum (P_m - P_walk)^2 - sigma^2 ) / sqrt( sum P_walk^2 - sigma^2 ),
//   delta:   sqrt( sum (D_m - D)^2 / sum (D + R_d + T_d)^2 ),  D = R_specular + T_ballistic,
// (the delta one is the fraction of all returned light a model misses under uniform light),
// summed over bins, incidences, channels and sides, where sigma^2 = sum of the walk bins'
// squared standard errors: E[(P_m - P_hat)^2] = (P_m - P)^2 + sigma_b^2, so subtracting it
// makes both sums unbiased for the noise-free quantities (clamped at 0). This is the relative
// RMS image error under uniform illumination of a flat patch seen from all directions; a scene
// lit by a small light weights some bins more, so it is a prediction, not a bound.
// Cost order (README "Speed and accuracy"): lambert < first-order < table < random-walk.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "renderer/camera.h"
#include "renderer/layered_material.h"
#include "renderer/scene.h"

namespace lamina {

struct AutoSettings {
  double tolerance = 0.05;
  int incidences = 4;           // mu_j = (j + 0.5) / incidences
  int bins_theta = 6;           // coarse grid of the prediction
  int bins_phi = 12;
  std::uint64_t walks = 20000;      // per incidence, first round (then doubled)
  std::uint64_t max_walks = 80000;  // per incidence, in all rounds (a table build: 8 x 50000)
  std::uint64_t seed = 11;
};

struct AutoChoice {
  SubsurfaceMode mode = SubsurfaceMode::RandomWalk;
  // Predicted relative RMS errors; random-walk is 0 by definition (the reference).
  double error_lambert = 0.0, error_first_order = 0.0, error_table = 0.0;
  // sqrt(sum sigma_b^2 / sum P^2): the relative noise of the walk's coarse table, the scale
  // below which the diffuse errors are not resolved (their noise-corrected estimates scatter by
  // about noise_floor * (2 / number of terms)^(1/4)).
  double noise_floor = 0.0;
  std::uint64_t walks = 0;  // per incidence and side, in all rounds
  double seconds = 0.0;  // time of the prediction
  // "chose first-order (predicted error 0.012 <= 0.05; lambert 0.31, first-order 0.012, table 0.021)"
  std::string reason;
};

// The prediction for one material (its base stack: texture-driven parameters are not varied).
AutoChoice choose_subsurface_mode(const LayeredMaterial& material, const AutoSettings& settings);

// Which glTF material slots the camera sees directly: camera rays through a grid of at most
// grid x grid film positions over the whole image (pixel centres of a coarse grid; all pixels
// if the image is smaller). Materials seen only indirectly (through a transmitting stack, in
// reflections, by their light on other surfaces) are NOT found.
std::vector<bool> camera_visible_materials(const Scene& scene, const Camera& camera, int width, int height, int grid = 64);

// One choice per glTF material slot (default-constructed for non-layered slots). A slot whose
// `visible` entry is false (when `visible` is given) is not predicted: it costs nothing and is
// shaded as lambert (its albedo walks run only if some path reaches it), reason "not visible".
std::vector<AutoChoice> choose_subsurface_modes(const LayeredBindings& bindings, const AutoSettings& settings,
                                                const std::vector<bool>* visible = nullptr);

}  // namespace lamina
