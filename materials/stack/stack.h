// A stack of plane-parallel homogeneous layers (Hanrahan and Krueger 1993, section 3).
//
// Layers run from the top (the side the surface normal points to, +z) down. Coefficients are per
// millimetre, thicknesses in millimetres; only optical depths matter (docs/contracts.md, "Units").
#pragma once

#include <limits>
#include <string>
#include <vector>

#include "materials/base/spectrum.h"
#include "materials/interfaces/microsurface.h"  // InterfaceModel

namespace lamina {

constexpr double kInfiniteThickness = std::numeric_limits<double>::infinity();

// One Henyey-Greenstein lobe of a layer's phase function. A composite layer has one lobe per
// component: its scattering coefficient is w_i * sigma_s_i (volume fraction times the
// component's own), so the layer's phase function in channel c is the scattering-weighted
// mixture  p_c(cos) = sum_i sigma_s_{i,c} p_HG(cos; g_{i,c}) / sum_i sigma_s_{i,c}
// (Hanrahan and Krueger eq. 8; docs/contracts.md, "Material file").
struct PhaseLobe {
  Spectrum sigma_s;  // this lobe's share of the layer's scattering coefficient, 1/mm
  Spectrum g;        // HG asymmetry, |g| < 1
};

struct Layer {
  std::string name;
  double ior = 1.0;
  double thickness = 0.0;  // mm; kInfiniteThickness for a semi-infinite (last) layer
  Spectrum sigma_a;        // absorption, 1/mm (sum of w_i sigma_a_i for a composite)
  std::vector<PhaseLobe> lobes;
  // GGX alpha of the interface BELOW this layer (the next layer's top, or the stack's bottom on a
  // dielectric): 0 smooth. Only with LayerStack::interface_model EnergyConserving (validate_stack).
  double bottom_roughness = 0.0;
  // The interface BELOW this layer transmits diffusely (materials/interfaces/diffuse_interface.h:
  // PROSPECT's plate surface); never also rough (validate_stack). See LayerStack::diffuse_interface.
  bool bottom_diffuse = false;

  Spectrum sigma_s() const;  // sum of the lobes' scattering
  Spectrum sigma_t() const { return sigma_a + sigma_s(); }
  // Single-scattering albedo sigma_s/sigma_t per channel (0 where sigma_t = 0).
  Spectrum albedo() const;
  bool semi_infinite() const { return thickness == kInfiniteThickness; }
  // Optical depth tau = sigma_t * thickness in channel c (infinity for a semi-infinite layer
  // unless sigma_t = 0, where it is 0).
  double optical_depth(int channel) const;

  // The normalised phase function of channel c: the lobes' mixture (see PhaseLobe).
  double phase(int channel, double cos_theta) const;
  // Chooses a lobe of channel c with probability proportional to its scattering (u in [0,1)).
  int choose_lobe(int channel, double u) const;
};

// A single-layer homogeneous layer with one HG lobe.
Layer make_layer(std::string name, double ior, double thickness, Spectrum sigma_a,
                 Spectrum sigma_s, Spectrum g);

// What lies below the last layer.
struct Below {
  enum class Kind { Dielectric, Lambert };
  Kind kind = Kind::Dielectric;
  double ior = 1.0;  // Dielectric: the index of the medium below (air under a leaf)
  Spectrum albedo;   // Lambert: an opaque diffuse substrate (flesh under skin)
};

struct LayerStack {
  std::string name;
  double above_ior = 1.0;
  // GGX alpha of the top interface (interface 0; materials/interfaces/microfacet.h): 0 is a smooth
  // (mirror) interface, the model of Hanrahan and Krueger; > 0 a rough dielectric whose
  // reflection is a glossy lobe and whose transmission spreads directions. With the
  // single-scattering model only for stacks that do not transmit (validate_stack).
  double top_roughness = 0.0;
  // The top interface (interface 0) transmits diffusely (materials/interfaces/diffuse_interface.h);
  // never also rough (validate_stack). JSON "top_diffuse".
  bool top_diffuse = false;
  // The rough interfaces' model (materials/interfaces/microsurface.h): EnergyConserving, the
  // default (of this struct and of a material file without "interface_model"), is Heitz et al.'s
  // multiple-scattering microsurface at every rough interface (top_roughness and each layer's
  // bottom_roughness), from both sides, on any stack; SingleScattering, explicit only, is the
  // top-only single-scattering interface (Walter et al., Mitsuba 3's roughdielectric), for
  // comparisons with renderers that use it. Smooth stacks are the same under either.
  InterfaceModel interface_model = InterfaceModel::EnergyConserving;
  std::vector<Layer> layers;
  Below below;

  // True if light can leave through the bottom (a transmitting medium below, and no
  // semi-infinite layer).
  bool transmits() const;
  // Every coefficient (absorption, each lobe's scattering and g, the substrate's albedo) is the
  // same in all channels: the random walk's three channels are then equal bit for bit
  // (test RandomWalk.GreyStackKeepsChannelsIdentical), and a tally need only keep one.
  bool grey() const;
  // The top interface is rough: roughness > 0 and an index step there (an index-matched top is
  // no interface at all, rough or not).
  bool rough_top() const { return top_roughness > 0.0 && !layers.empty() && above_ior != layers[0].ior; }
  // The single-scattering rough top (the model of microfacet.h's RoughDielectric, which the walk,
  // its connections and the renderer's glossy lobe special-case).
  bool single_scattering_top() const { return rough_top() && interface_model == InterfaceModel::SingleScattering; }
  // GGX alpha of interface k (numbered as below: 0 the top, N the bottom) if it is an energy-
  // conserving rough interface (roughness > 0 and an index step), else 0.
  double energy_conserving_alpha(int k) const;
  // Some interface is an energy-conserving rough one.
  bool energy_conserving_rough() const;
  // Interface k (numbered as below: 0 the top, N the bottom) is a diffuse one: flagged
  // (top_diffuse, layers[k-1].bottom_diffuse) and an index step there (an index-matched interface
  // is no interface at all).
  bool diffuse_interface(int k) const;
  // Some interface is a diffuse one.
  bool any_diffuse_interface() const;
  // "top_diffuse" or "layers[i].bottom_diffuse" (the JSON path) of the first diffuse interface, or
  // "" if there is none: for the one-line refusals of the modes that do not model it.
  std::string first_diffuse_interface_path() const;
  // Index of refraction on the far side of interface k: interface 0 is the top surface
  // (above_ior | layers[0]); interface k (1 <= k < N) lies between layers[k-1] and layers[k];
  // interface N is the bottom (layers[N-1] | below).
  double ior_above_interface(int k) const;
  double ior_below_interface(int k) const;
};

// The same stack seen from below: layers in reverse order, the medium below becomes the medium
// above and vice versa. The renderer uses it when the light or the camera is on the back side
// (a leaf lit from behind): f(stack, wi, wo) with wi.z < 0 equals f(flipped(stack), wi', wo')
// with the z components negated. Only defined for a stack that transmits (a dielectric below
// and no semi-infinite layer); throws std::invalid_argument otherwise.
LayerStack flipped(const LayerStack& stack);
// The same into *out, reusing its storage (no allocation once its vectors have grown): for
// per-hit stacks built in a scratch. `out` must not be `&stack`.
void flip_into(const LayerStack& stack, LayerStack* out);

// The similarity relation (van de Hulst; Wyman, Patterson and Wilson 1989): every lobe's
// scattering becomes sigma_s (1 - g) with g = 0, per channel; absorption, indices, thicknesses
// and the substrate stay. The transformed medium has the same diffusion-limit transport (the
// same reduced scattering coefficient) and about 1/(1 - g) times fewer scattering events, but it
// is an APPROXIMATION: low orders and near-specular directions differ (the random walk's
// WalkOptions::similarity_after uses it after a number of exact events; the bias is measured).
// Into *out, reusing its storage; `out` must not be `&stack`.
void similarity_transform_into(const LayerStack& stack, LayerStack* out);

// The same stack with smooth interfaces (top_roughness and every bottom_roughness 0): what the
// modes that do not model a rough interface (first order, tables) use; the renderer warns when
// it does so.
LayerStack with_smooth_top(LayerStack stack);

// Every number of the stack that affects light transport, exactly (hexadecimal floating point),
// in a fixed order: equal fingerprints mean the same physics (names are left out). For cache
// keys (the renderer's walk cache).
std::string stack_fingerprint(const LayerStack& stack);

// Returns an empty string if the stack is physically valid, else the first problem found, in
// the form "layers[1].sigma_a[2]: must be finite and >= 0" (the JSON path of the bad value).
std::string validate_stack(const LayerStack& stack);

}  // namespace lamina
