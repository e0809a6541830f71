// `lamina render --subsurface auto --tolerance E`: per layered material, the cheapest shading
// model whose predicted error against the full random walk is within E.
//
// The prediction (no image is rendered). A pixel that sees a flat patch of the stack from a
// direction of cosine mu shows L = sum_B P(mu -> B) Lbar_in(B) + D(mu) L_in(mirror), where
// P(mu -> B) = f(B) Omega_proj(B) is the fraction of the power arriving from the viewer's
// direction that leaves into bin B (by reciprocity, the weight of the light from B in the
// pixel; across an index change up to the constant (n_v / n_l)^2, the same for every model),
// Lbar_in(B) the mean incident radiance over B, and D = R_specular + T_ballistic the delta
// parts. So the models are compared through P and D at incidences mu, from both sides of a
// stack that transmits:
//   walk:        brdf_table_monte_carlo on a coarse grid of bins, with standard errors; or, with
//                adding-doubling tables (the default) and a stack it resolves, the adding-doubling
//                bins, exact (standard errors 0: one pass, no walks);
//   lambert:     albedo/pi on the reflect side (the mode's albedo: lambert_albedo()), 0 on the
//                transmit side, and no delta parts;
//   first-order: brdf_table_first_order (exact single-scattering bin averages) plus the exact D;
//   table:       the walk, linearly interpolated between the table's nodes, with the noise of a
//                table of TableSettings' size; D exact.
// Two relative errors per incidence and model m, both over the three channels:
//   shape (a point light: the pixel is one bin):
//      sqrt( sum_B,c (P_m - P)^2 ) / sqrt( sum_B,c P^2 )
//   uniform (a uniform environment: the pixel is the directional albedo):
//      sqrt( sum_c (A_m + D_m - A - D)^2 ) / sqrt( sum_c (A + D)^2 ),  A = sum_B P,
// and the model's predicted error is the larger of
//   uniform: the worst view (incidences at the table's nodes, 89.9 degrees to normal, and both
//            sides): well resolved per view (the albedo's noise is small), and a bound on what
//            any pixel under broad light sees;
//   shape:   the RMS over those views (sums over views in numerator and reference): per view it
//            would need ~10^6 walks to resolve a few percent over 2 x 6 x 12 bins; and through a
//            Fresnel interface almost no light enters at grazing incidence (T ~ mu), where an
//            error relative to that view's own nothing would say nothing about the image. Each sum is corrected for the walk's
// noise: E[(P_m - P_hat)^2] = (P_m - P)^2 + sigma^2, so sigma^2 (the bins' squared standard
// errors; for A the variance of R_diffuse + T_diffuse) is subtracted from both the numerator
// and the reference sum (clamped at 0).
// The table's interpolation error, at the midpoints next to node j of evenly spaced nodes, is
// (P_{j-1} - 2 P_j + P_{j+1}) / 8 (linear interpolation of a smooth function: h^2 |P''| / 8
// with P'' ~ second difference / h^2); its own statistical error is the walk's noise scaled to
// the table's walks per node and, for the shape, to its finer bins (sum of sigma_b^2 ~ power / N
// whatever the bins; sum of P_b^2 falls as 1 / bin count).
// The adding-doubling reference in stages. Its cost grows as ~N^4 with the quadrature order N
// (N^3 per solution, ~N azimuthal modes), and the full order (the table mode's rule, 16 points,
// 24 or more for g 0.9) is rarely needed to decide. So the reference P is first solved at a low
// order N (AutoSettings::first_reference_points) and at N/2, Q, and the difference dP = P - Q is
// taken as a bound on P's own discretisation error in every norm below (the error falls fast
// with the order, so the difference from half the order overstates it; README "Adding-doubling",
// convergence table). Each metric is a ratio e = ||X - P|| / ||P|| of norms over bins, channels
// and views (shape: the sums over views; uniform: per view, then the worst), and with P moved by
// at most dP it moves by at most (triangle inequality on numerator and denominator)
//     delta = (||dX|| + e ||dP||) / (||P|| - ||dP||),
// where dX is how the model's difference X - P moves with P: -dP for lambert and first order (X
// does not depend on the reference), the interpolation bias of dP for the table (the bias is
// linear in P: B(P) - B(Q) = B(dP)). A model's delta is the larger of its two metrics' (the
// predicted error is their maximum). The choice is decided at order N when every model's
// predicted error is at least 2 deltas from the tolerance (as the walk's rounds use 2 standard
// deviations); otherwise N doubles (the previous stage is the new N/2) up to the full order,
// where the choice is made without an estimate, as before the stages. On the test stacks the
// bound exceeds the actual difference from the full-order prediction by a factor from 9.6 (the
// thin film's first-order error at 4 points) to over 10^5 (the triangle inequality assumes dP
// aligned with the model's difference, and N/2 is far worse than N); it still decides skin.json, skin_oily.json and contract_leaf.json of bench/bench_auto at
// tolerance 0.05 at 4 points, leaf.json at 8.
// Cost order (README "Speed and accuracy"): lambert < first-order < table < random-walk.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "renderer/scene/camera.h"
#include "renderer/layered/layered_material.h"
#include "materials/tables/layered_table.h"
#include "renderer/scene/scene.h"
#include "renderer/layered/walk_cache.h"
#include "renderer/layered/subsurface_mode.h"

namespace lamina {

struct AutoSettings {
  double tolerance = 0.05;
  TableSettings table;   // the table mode's settings; its nodes are the prediction's incidences
  int bins_theta = 6;    // coarse grid of the prediction
  int bins_phi = 12;
  std::uint64_t walks = 10000;      // per incidence, first round (then doubled)
  std::uint64_t max_walks = 40000;  // per incidence, in all rounds
  std::uint64_t seed = 11;
  // The adding-doubling reference in stages: first at this many quadrature points (and half as
  // many, for the estimate of its discretisation error), doubling until the choice is decided
  // or the full order (the table mode's rule) is reached; 0: the full order at once.
  int first_reference_points = 4;
  // Test hooks: switches for the tests, never set by the renderer.
  struct TestHooks {
    // With adding-doubling tables the reference is adding-doubling itself where it resolves the
    // stack (exact, no walks); true forces the walks (the two references agree).
    bool walk_reference = false;
    // Stop after the first stage, decided or not (its errors and their estimate).
    bool single_reference_stage = false;
  };
  TestHooks test_hooks;
};

// Predicted relative errors of the cheaper models against the walk (whose own error is 0).
struct ModeErrors {
  double lambert = 0.0, first_order = 0.0, table = 0.0;
  // The prediction's resolution (1 sigma of the estimates above where they are near 0, the
  // larger of the shape's and the uniform's): errors below it are not resolved.
  double noise = 0.0;
  // The part of `table` that is the table's own statistical error (1 sigma).
  double table_noise = 0.0;
};

// The two metrics of one view (or the worst over views): shape (a point light) and uniform (a
// uniform environment).
struct ViewErrors {
  ModeErrors shape, uniform;
};

struct AutoChoice {
  SubsurfaceMode mode = SubsurfaceMode::RandomWalk;
  // Predicted relative errors (the largest over incidences and sides); random-walk is 0.
  double error_lambert = 0.0, error_first_order = 0.0, error_table = 0.0;
  // The prediction's relative noise (the largest over incidences and sides).
  double noise_floor = 0.0;
  std::uint64_t walks = 0;  // per incidence and side, in all rounds
  // The adding-doubling reference's quadrature points (0: the walk's reference) and, when below
  // the full order, the estimated discretisation error of each predicted error (else 0).
  int reference_points = 0;
  double discretisation_lambert = 0.0, discretisation_first_order = 0.0, discretisation_table = 0.0;
  double seconds = 0.0;  // time of the prediction
  // "chose first-order (predicted error 0.012 <= 0.05; lambert 0.31, first-order 0.012, table 0.021)"
  std::string reason;
  bool cached = false;  // read from a WalkCache (seconds is then the original prediction's)
  bool visible = true;  // false: not seen by camera rays, not predicted (shaded as lambert)
};

// The prediction for one material (its base stack: texture-driven parameters are not varied).
AutoChoice choose_subsurface_mode(const LayeredMaterial& material, const AutoSettings& settings);

// The predicted errors for one view: incidence cosine mu on the top of the stack (or, with
// from_below, of the flipped stack), from `walks` walks at mu and at the table nodes around it
// (the table's error is its actual interpolation there). Used by the tests of every mode
// against the walk, and to explain a choice.
ViewErrors predict_view_errors(const LayeredMaterial& material, double mu, bool from_below,
                               const AutoSettings& settings, std::uint64_t walks);

// One choice per glTF material slot (default-constructed for non-layered slots). A slot whose
// `visible` entry is false (when `visible` is given) is not predicted: it costs nothing and is
// shaded as lambert (its albedo walks run only if some path reaches it), reason "not visible".
// With a cache (renderer/layered/walk_cache.h), predictions made before for the same stack and settings
// by the same lamina build are read from it, and new ones are stored.
std::vector<AutoChoice> choose_subsurface_modes(const LayeredBindings& bindings, const AutoSettings& settings,
                                                const std::vector<bool>* visible = nullptr,
                                                const WalkCache* cache = nullptr);

}  // namespace lamina
