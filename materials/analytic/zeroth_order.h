// Unscattered ("zeroth-order") transport through a layer stack: the specular reflection, the
// ballistic transmission and the fraction of the light that collides, with every Fresnel
// reflection between every pair of interfaces summed in closed form.
//
// Method: the 1D adding method for collimated light (van de Hulst, "Multiple Light Scattering",
// 1980, ch. 3; Stokes 1862 for a plate). Unscattered light keeps the horizontal invariant
// s = n sin(theta) (Snell), so at a given incidence every layer sees one cosine mu_k and every
// element of the stack (interface or layer) acts on a single number, the power of the beam:
//   interface between media a, b:   R = Fresnel(mu_a; n_a, n_b) from either side, T = 1 - R
//                                   (Fresnel reflectance is the same from both sides at
//                                   Snell-related angles: Born and Wolf 1.5.3); R = 1, T = 0
//                                   where the direction cannot exist on the far side (TIR).
//   layer k:                        R = 0, T = t_k = exp(-tau_k / mu_k) per pass.
// Two elements A over B combine as (the geometric series of the bounces between them)
//   T_AB  = T_A T_B / (1 - R'_A R_B),
//   R_AB  = R_A  + T_A^2 R_B  / (1 - R'_A R_B),      (seen from above)
//   R'_AB = R'_B + T_B^2 R'_A / (1 - R'_A R_B),      (seen from below)
// where R' is the reflectance seen from below. T is the same both ways for every element, so
// for every combination.
//
// Conventions as docs/contracts.md: light arrives from above (the side +z points to); the results
// are fractions of the incident power per RGB channel.
#pragma once

#include <array>
#include <vector>

#include "materials/base/spectrum.h"
#include "materials/stack/stack.h"

namespace lamina {

// Reflectance and transmittance of a part of the stack for unscattered light at one horizontal
// invariant. R_top: light arriving from above and going back up; R_bottom: from below, back
// down; T: through it (either way).
struct SpecularElement {
  double R_top = 0.0;
  double R_bottom = 0.0;
  double T = 1.0;
};

// A over B (the adding formulas above). Exact zero where a trapped beam would make 0/0 (both
// reflect totally towards each other: then no light can enter the gap either).
SpecularElement add_elements(const SpecularElement& a, const SpecularElement& b);

// The unscattered transport seen from inside layer k (one channel, one invariant).
struct LayerTransport {
  double mu = -1.0;        // cosine of the beam in the layer; < 0 if it cannot propagate there
  double t = 0.0;          // one-pass transmittance exp(-tau / mu)
  double one_minus_t = 1;  // -expm1(-tau / mu): the collision probability of one pass
  double tau = 0.0;        // optical depth of the layer in this channel
  // Everything above layer k (interfaces 0..k and layers 0..k-1). above.T carries light between
  // the outside above and layer k, above.R_bottom sends light in layer k back down into it.
  SpecularElement above;
  // Everything below layer k (interfaces k+1..N, layers k+1..N-1, and what lies below).
  // below.R_top sends light in layer k back up into it; below.T carries it to the outside below
  // (into the substrate for a Lambert bottom; 0 under a semi-infinite layer).
  SpecularElement below;
};

struct StackTransport {
  std::vector<LayerTransport> layers;
  SpecularElement whole;  // the whole stack, above medium to below medium (or substrate)
};

enum class Outside { Above, Below };

// Unscattered transport of channel `channel` for a beam whose cosine is |cos_theta| in the
// outside medium `side` (the above medium with above_ior, or the medium below with below.ior;
// Below requires a dielectric below). Every layer's cosine follows Snell from there.
StackTransport unscattered_transport(const LayerStack& stack, int channel, double cos_theta,
                                     Outside side = Outside::Above);
// All channels at once (the cosines and Fresnel terms are shared): what the hot paths use.
std::array<StackTransport, kChannels> unscattered_transport_rgb(const LayerStack& stack, double cos_theta,
                                                                Outside side = Outside::Above);

struct ZerothOrder {
  // All unscattered light that leaves through the top: the Fresnel reflection at the top plus
  // the light reflected, unscattered, by deeper interfaces that comes back out. All of it leaves
  // in the mirror direction (the invariant s is kept), so it is all a delta lobe.
  Spectrum R_specular;
  // Unscattered light that leaves through the bottom, in the direction Snell gives from the top
  // (parallel to the incidence when the media above and below have the same index).
  // 0 for a Lambert substrate or a semi-infinite layer.
  Spectrum T_ballistic;
  // Light that collides at least once: the sum of collided_in_layer and reaches_substrate.
  // Computed directly (not as 1 - R - T), so it keeps full relative precision when it is tiny;
  // R_specular + T_ballistic + collided = 1 holds to rounding (about 1e-16).
  Spectrum collided;
  std::vector<Spectrum> collided_in_layer;  // first collision (absorption or scattering) in layer k
  Spectrum reaches_substrate;               // unscattered light hitting the Lambert substrate
  std::vector<double> cos_layer;            // |cos| of the beam in layer k (< 0: cannot get there)
  double cos_below = -1.0;                  // |cos| of T_ballistic's direction below (< 0: none)
};

// cos_theta_i = wi.z > 0 in the medium above.
ZerothOrder zeroth_order(const LayerStack& stack, double cos_theta_i);

}  // namespace lamina
