// The random walk of light inside a layer stack: THE one Monte Carlo transport of Lamina, driven
// by `lamina brdf` (materials/brdf/brdf_table) and by the renderer's layered surface. It knows nothing
// of rays, scenes or lights: it sees a LayerStack, an incident direction and an Rng.
//
// Conventions (docs/contracts.md): local frame with +z the outward normal of the top layer; wi points
// away from the surface towards the light (wi.z > 0). Inside the walk, `d` is the PROPAGATION
// direction of the light (so the light enters along -wi, refracted). An exit direction is the
// outside propagation direction, i.e. the `wo` of the BRDF (wo.z > 0) or BTDF (wo.z < 0).
//
// What the walk estimates (Hanrahan and Krueger 1993, section 5 "Monte Carlo"): a photon packet
// of unit incident power per unit area enters with weight (1 - R(wi)) (the specular Fresnel
// reflection R is the caller's delta lobe), flies, scatters, reflects and refracts at the smooth
// interfaces, and ends by leaving the stack (top or bottom), on a zero weight (absorbed), or by
// Russian roulette. Expected values over walks:
//   E[exit weight, side and direction in a set A] = fraction of the incident power leaving in A,
//   E[sum over events of throughput * connection_weight(w)] = f(wi, w) (BRDF or BTDF, 1/sr),
// see connection_weight() for the derivation.
#pragma once

#include <functional>
#include <limits>
#include <vector>

#include <glm/geometric.hpp>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include "materials/interfaces/diffuse_interface.h"
#include "materials/interfaces/microfacet.h"
#include "materials/interfaces/microsurface.h"
#include "materials/base/sampling.h"
#include "materials/base/spectrum.h"
#include "materials/stack/stack.h"
#include "materials/walk/walk_options.h"

namespace lamina {

// One scattering event of a walk.
struct ScatterEvent {
  enum class Kind { Volume, Substrate };
  Kind kind = Kind::Volume;
  int order = 1;        // 1 for the first scattering event of the walk, 2 for the second, ...
  int layer = 0;        // index into stack.layers (the last layer for a substrate event)
  double depth = 0.0;   // mm below the top of that layer (= its thickness for the substrate)
  glm::dvec3 direction{0.0, 0.0, -1.0};  // propagation direction inside the layer, before scattering
  // Volume: the packet's weight after the collision, i.e. the scattered power (single-scattering
  //   albedo already applied).  Substrate: the power arriving at the substrate (its albedo is
  //   applied by connection_weight and, for the continuing walk, after the event).
  // In both cases the event contributes throughput * connection_weight(stack, event, w) to
  // f(wi -> w), per unit incident irradiance.
  Spectrum throughput;
  // The walk's hero channel (it samples every decision in this channel's coefficients; see the
  // spectral MIS notes in random_walk.cpp). connection_pdf uses it.
  int hero = 0;
  // The walk had switched to WalkOptions::similar when this event scattered: its phase function
  // and the attenuation of its way out are those of the similar stack (its collision, and the
  // throughput, may still be the exact stack's: the switch's own event).
  bool similar = false;
  // The flight that ended here started at the walk's previous event, a volume event in the same
  // layer (and the same stack), along a direction sampled classically from its phase function
  // (not guided), with no interface met on the way: `direction` then has the density
  // phase(previous.direction . direction). The renderer's direction-MIS connections use it.
  bool flight_from_previous = false;
};

struct WalkResult {
  enum class Side { None, Top, Bottom };
  enum class End {
    ExitTop,       // refracted out through the top interface
    ExitBottom,    // refracted out through the bottom (transmitting stacks), or lost into the
                   // depth of a semi-infinite layer that does not attenuate some channel
    Absorbed,      // the weight became exactly zero (albedo 0 in the volume or at the substrate)
    Roulette,      // killed by Russian roulette (unbiased: survivors carry weight / q)
    Lost,          // a flight parallel to the layers that never ends (measure zero; guarded)
  };
  Side side = Side::None;
  End end = End::Absorbed;
  glm::dvec3 direction{0.0};  // outside propagation direction on exit (= wo), else 0
  Spectrum weight;            // exit weight (fraction of incident power), 0 if no exit
  int scatter_count = 0;      // volume + substrate scattering events before the exit / end
  int interactions = 0;       // all events: scatterings and interface reflections/refractions
  // The walk left straight from its last scattering event (no interface reflection since then,
  // and at least one event). Then, if WalkOptions::compute_exit_pdf, exit_pdf is
  // connection_pdf(stack, last event, direction): the solid-angle density (outside measure) of
  // this exit in the hero's coefficients.
  bool straight_from_last_event = false;
  double exit_pdf = 0.0;
  // Direct estimate of the absorbed power (what collisions and the substrate removed), for
  // energy-balance checks; its expectation equals 1 - R - T. 0 unless WalkOptions::tally_absorbed.
  Spectrum absorbed;
  // The walk's weight when it passed WalkOptions::forced_exponential_after interactions (0 if
  // it never did). From there a constant survival decides its fate: unbiased, but the few
  // survivors carry weights that grow exponentially, so an average over walks all but never
  // sees this power come out. Its mean over walks, `unresolved` in lamina brdf, bounds what the
  // totals may miss beyond their standard errors (docs/random_walk.md, "Heavy tails").
  Spectrum cut_weight;
  // Rough top interface (LayerStack::top_roughness): the walk's direction in layer 0 as it
  // reached the top before leaving (what exit_pdf_for_mis needs: many inside directions reach one
  // outside direction), and a direct estimate of the power lost by the single-scattering
  // microfacet model (directions sampled below the facets), at the entry and inside. Its
  // expectation closes the energy balance: R + T + absorbed + interface_loss = 1 - R_glossy.
  glm::dvec3 top_inside{0.0};
  Spectrum interface_loss;
  // Energy-conserving rough interfaces (LayerStack::interface_model; materials/interfaces/
  // microsurface.h), which the walk samples exactly (weight 1, nothing lost):
  // entry_reflection: the rough top reflected the light at its entry (the glossy lobe: an exit at
  //   the top with scatter_count 0 and weight 1; with a smooth or single-scattering top the walk
  //   never reflects at entry, the caller adds that part). A diffuse top met from its dense side
  //   (above_ior > layers[0].ior) reflects at entry the same way (diffusely); met from its light
  //   side it leaves the specular reflection to the caller, as a smooth top;
  // crossed_rough: the walk's straight exit (straight_from_last_event) crossed such an interface
  //   other than the top on its way out (an inner one, or the bottom), or any diffuse interface
  //   (materials/interfaces/diffuse_interface.h), the top included. The light connections
  //   through one are sampled (prepare_exit with an Rng) and have no MIS density there: they
  //   alone estimate such exits, whose exit_pdf stays 0. An exit through the top alone has its
  //   density (from top_inside, prepare_exit_through), and the connections through it theirs.
  bool entry_reflection = false;
  bool crossed_rough = false;
};

using EventCallback = std::function<void(const ScatterEvent&)>;

// The walk draws its hero channel itself (uniformly, from rng).
constexpr int kRandomHero = -1;

// Runs one walk. wi: unit, towards the light, wi.z > 0 (light arriving from above). on_event may
// be empty. The result's weights are per unit incident power (the specular part R(wi) is not
// included; see zeroth order / fresnel_dielectric).
// hero: kRandomHero (the default, or any value outside 0..kChannels-1) draws the hero channel
// uniformly from rng; 0..kChannels-1 uses the caller's channel. The weights are the one-sample
// balance heuristic over UNIFORMLY chosen heroes, so a caller that chooses must make the hero
// uniform over the channels marginally and independent of everything else the walk draws (the
// renderer stratifies it over a pixel's samples: renderer/layered/hero_strata.cpp). The walk's
// uniform for the hero is drawn either way, so the rest of its random numbers come from the same
// place in rng.
WalkResult random_walk(const LayerStack& stack, const glm::dvec3& wi, Rng& rng,
                       const EventCallback& on_event = {}, const WalkOptions& settings = {},
                       int hero = kRandomHero);

// The stack an event of a walk with these settings scattered in, whose phase function and way
// out its connections use: the similar stack from the similarity switch on (ScatterEvent::
// similar), else the walk's own.
inline const LayerStack& stack_of_event(const LayerStack& stack, const WalkOptions& settings, const ScatterEvent& e) {
  return e.similar && settings.similar ? *settings.similar : stack;
}

// What a walk needs from its stack and settings that is the same for every walk: each layer's
// coefficients summed over its lobes, their logarithms and ratios, the phase function's shape,
// the guiding, whether the stack is grey (then the walk keeps no per-channel densities). Prepared
// once (prepare_walk), a plan serves any number of walks on any thread: it is read only, and it
// points to the stack (and to settings.similar), which must outlive it. The overload of
// random_walk that takes a stack prepares a plan at every call, which a short walk pays per
// photon (`lamina brdf` on a thin slab: about five events a walk) and a long one does not notice.
struct WalkPlan {
  struct LayerCache {
    Spectrum sigma_t, sigma_s;
    Spectrum log_sigma_t;             // -inf where sigma_t = 0
    Spectrum albedo, absorbed_share;  // sigma_s / sigma_t and sigma_a / sigma_t (0 where sigma_t = 0)
    bool grey_phase = false;
    // Every lobe has this g in channel c (one_g[c]; skin's composite layers: two lobes, one g):
    // then the lobe choice cannot change the sampled direction: no lobe is chosen and no uniform
    // drawn for it.
    Spectrum g;
    bool one_g[kChannels] = {false, false, false};
    Spectrum v0;          // guided walks: Dwivedi's v0 per channel (0: not guided)
    double guiding = 0.0; // the probability of the guided technique for flights from here
  };
  const LayerStack* stack = nullptr;
  WalkOptions settings;
  std::vector<LayerCache> layers;  // [0, n): the stack's layers; [n, 2n): the similar stack's, if may_switch
  bool may_switch = false;         // settings.similarity_after applies (a similar stack of as many layers)
  bool spectral = true;            // false: a grey stack (and no guiding), whose channels never differ
  bool rough = false;              // stack->single_scattering_top(), and then its top interface
  RoughDielectric top;
  // Energy-conserving rough interfaces: interface k's microsurface (k = 0 the top ... N the
  // bottom; alpha 0 where the interface is smooth), and whether there is any.
  bool microsurfaces_used = false;
  std::vector<MicrosurfaceDielectric> microsurfaces;
  bool rough_at(int k) const { return microsurfaces_used && microsurfaces[k].distribution.alpha > 0.0; }
  // Diffuse interfaces (LayerStack::diffuse_interface): interface k's formulas (n_lo == n_hi
  // where it is not diffuse), and whether there is any.
  bool diffuse_used = false;
  std::vector<DiffuseInterface> diffuse;
  bool diffuse_at(int k) const { return diffuse_used && diffuse[k].n_lo != diffuse[k].n_hi; }
};
void prepare_walk(const LayerStack& stack, const WalkOptions& settings, WalkPlan* plan);
WalkResult random_walk(const WalkPlan& plan, const glm::dvec3& wi, Rng& rng, const EventCallback& on_event = {},
                       int hero = kRandomHero);

// Everything about the unscattered path from a layer straight out to the outside direction w
// that does not depend on where in the layer the event is or where it came from: Snell's law
// fixes the direction in every layer, so per layer the inside direction, the Fresnel
// transmissions of the interfaces on the way, (n_out / n_layer)^2, the refraction's Jacobian and
// the optical depth of the layers beyond are known from w alone. Prepared once per outside
// direction (a light sample), it leaves an event only its phase function and its own layer's
// attenuation (connect_direct). prepare_exit reuses out's storage.
struct ExitDirection {
  struct LayerExit {
    bool exists = false;        // some direction in this layer refracts out to w
    glm::dvec3 inside{0.0};     // that propagation direction
    double mu_inside = 0.0;     // |cos| of it
    double fresnel_t = 0.0;     // product of (1 - R) over the interfaces crossed
    double radiance_scale = 0.0;  // fresnel_t * (n_out / n_layer)^2
    double jacobian = 0.0;      // d(omega_inside) / d(omega_outside) = (n_out/n_layer)^2 mu_out / mu_inside
    bool grey_phase = false;    // the layer's phase function is the same in every channel
    bool single_lobe = false;   // ... and one HG lobe (all its lobes share one g): single_g
    double single_g = 0.0;
    Spectrum sigma_t, sigma_s;  // the layer's coefficients (sums over its lobes), for the connections
    Spectrum depth_rate;        // optical depth per mm of depth travelled in this layer: sigma_t / mu
    Spectrum tau_beyond;        // optical depth of the layers between this one and the outside
    double min_depth_rate = 0.0;  // the smallest channel of depth_rate, and of tau_beyond
    double min_tau_beyond = 0.0;
  };
  glm::dvec3 w{0.0, 0.0, 1.0};
  bool up = true;
  double mu_out = 0.0;
  std::vector<LayerExit> layers;  // empty: w itself cannot be reached (grazing, or no transmission)
  // Guided walks (WalkOptions::guiding): the walk leaves a volume event along the inside
  // direction with the mixture density; per layer, the guided technique's probability, direction
  // density and stretched optical depths.
  struct GuidedExit {
    double guiding = 0.0;    // the guided technique's probability for flights from this layer
    Spectrum direction_pdf;  // dwivedi_pdf at the inside direction (isotropic where unguided)
    Spectrum depth_rate, tau_beyond;
  };
  std::vector<GuidedExit> guided;  // per layer, when guiding > 0
};
//
// A rough top interface (LayerStack::top_roughness > 0) refracts many inside directions into w:
// prepare_exit then SAMPLES one, as pbrt-v4's LayeredBxDF pre-samples its exit direction: a
// microfacet normal m ~ D_w (visible normals from w, two uniforms u_interface), the refraction t
// of w through m into layer 0; layer 0's inside direction is -t, its radiance_scale the
// estimate f_t(w, t) |t.z| / p(t | w) = (1 - F) G2/G1(w) (n_above / n_0)^2 of the rough
// transmission, and its `jacobian` the ratio pdf_walk(w | t) / p(t | w) of the walk's own
// exit density through the facets to this sampling density, so that connect_direct's
// pdf_for_mis is the walk's density of the pair (t, w) over p(t | w): the power heuristic of a
// light density against it is the heuristic of the two strategies' densities of the whole pair
// (light: p_light(w) p(t | w); walk: phase and flight to t, then the facets to w). Only with
// uniform random u_interface is the connection unbiased (the default is for smooth stacks, which
// ignore it). Deeper layers follow from t by Snell's law through the smooth inner interfaces.
//
// Energy-conserving rough interfaces (any of them, LayerStack::energy_conserving_alpha) are
// crossed the same way, with `rng`: from the outside inwards, at each such interface one walk on
// its microsurface (MicrosurfaceDielectric::sample) from the direction beyond it; if it
// transmits, the direction it reaches is the next layer's (and Snell's law goes on from there),
// if it reflects the layers behind cannot be reached this time. Its estimate of the interface's
// transmission for radiance, f_t(w, t) |t.z| / P(t | w) = (n_beyond / n_layer)^2 by
// reciprocity (microsurface.h), is what the n^2 law gives anyway: radiance_scale keeps its form.
// Through the top alone the MIS density ratio is known in closed form although P is not: the
// walk's exit density P(w | t) over the connection's P(t | w) is (n_above / n_0)^2 |w.z| / |t.z|
// by the same reciprocity, so `jacobian` is the smooth interface's (n_out / n_layer)^2 mu_out /
// mu (for w.z > 0, with prepare_exit_through's top_inside on the walk's side). Behind any other
// such interface no closed-form density of the walk's own exits exists: those layers get
// jacobian 0 (so pdf_for_mis 0: the connections estimate those exits alone,
// WalkResult::crossed_rough). Without an rng, the layers behind such an interface are unreachable.
// Diffuse interfaces (materials/interfaces/diffuse_interface.h) are crossed likewise, with `rng`:
// the inside direction is cosine-sampled, and the crossing's estimate of the radiance
// transmission is (n_beyond / n_layer)^2 (1 - F(mu_beyond)) out of a dense layer and
// 1 - F(mu_inside) out of a light one (random_walk.cpp); jacobian 0 behind any of them.
void prepare_exit(const LayerStack& stack, const glm::dvec3& w, ExitDirection* out, double guiding = 0.0,
                  glm::dvec2 u_interface = {0.5, 0.5}, Rng* rng = nullptr);
// The stack's top interface as a rough dielectric (+z outside, -z layer 0); meaningful when
// stack.rough_top().
RoughDielectric top_interface(const LayerStack& stack);
ExitDirection prepare_exit(const LayerStack& stack, const glm::dvec3& w, double guiding = 0.0);
// Rough top (single-scattering or energy-conserving): the same for a given inside direction,
// `inside_up` the propagation direction in layer 0 towards the top (z > 0), e.g.
// WalkResult::top_inside, to weight the walk's own exit.
void prepare_exit_through(const LayerStack& stack, const glm::dvec3& w, const glm::dvec3& inside_up,
                          ExitDirection* out, double guiding = 0.0);

// An event's direct exit towards a prepared direction: its connection_weight and its
// exit_pdf_for_mis (materials/walk/walk_estimator.h), computed together because they share the phase
// function values and the attenuations.
struct DirectExit {
  Spectrum weight;            // connection_weight
  double pdf_for_mis = 0.0;   // exit_pdf_for_mis: the walk's exit density, mean over the heroes
  double pdf_hero = 0.0;      // connection_pdf: the same in the event's own hero channel
  double phase = 0.0;         // a volume event in a layer of one grey lobe: its phase function
                              // value towards the inside direction (else 0)
};
DirectExit connect_direct(const LayerStack& stack, const ScatterEvent& event, const ExitDirection& exit);

// The event's distance (mm) to the side of its layer that the way out towards the prepared
// direction leaves through: its depth going up, the rest of the layer going down.
inline double distance_to_exit_side(const LayerStack& stack, const ScatterEvent& event, const ExitDirection& exit) {
  return exit.up ? event.depth : stack.layers[event.layer].thickness - event.depth;
}

// A lower bound, over the channels, of the optical depth of the event's direct way out towards
// the prepared direction (infinity where there is none): exp(-bound) bounds its attenuation.
// Two multiplications, no exponential: for deciding cheaply which events are worth connecting.
// (Inline: the renderer asks it of every event for every light.)
inline double exit_optical_depth_bound(const LayerStack& stack, const ScatterEvent& event, const ExitDirection& exit) {
  if (exit.layers.empty() || !exit.layers[event.layer].exists) return std::numeric_limits<double>::infinity();
  const ExitDirection::LayerExit& path = exit.layers[event.layer];
  const double distance = distance_to_exit_side(stack, event, exit);
  return path.min_tau_beyond + (path.min_depth_rate > 0.0 ? path.min_depth_rate * distance : 0.0);
}

// The weight that turns an event into its contribution to the BRDF (w.z > 0) or BTDF (w.z < 0)
// (smooth top interfaces; through a rough one, one sample of it: see prepare_exit)
// towards the outside direction w (unit): f(wi -> w) += event.throughput * connection_weight.
// Zero where no inside direction refracts out to w, or w points to a side that does not transmit.
// Derivation: see random_walk.cpp, above its definition. (connect_direct with a prepared
// direction is the same, cheaper when many events connect to one w.)
Spectrum connection_weight(const LayerStack& stack, const ScatterEvent& event, const glm::dvec3& w);

// Smooth interfaces only (the adding method's closed form; a rough top is ignored):
// like connection_weight, but summed over ALL unscattered paths from the event out to w: the
// direct one, and those that are specularly reflected (any number of times) by the interfaces
// above and below before leaving, in closed form (the adding method of materials/analytic/zeroth_order).
// Then sum over every event of throughput * connection_weight_all_paths(w) estimates the whole
// f(wi -> w) by itself (every exit path is its last scattering event followed by unscattered
// bounces), and its order-1 events the first order exactly. connection_weight (direct path only)
// is what the renderer combines by MIS with the walk's straight exits; the walk's other exits
// carry the bounced paths there. Equal to connection_weight for an index-matched stack.
Spectrum connection_weight_all_paths(const LayerStack& stack, const ScatterEvent& event,
                                     const glm::dvec3& w);

// The part of connection_weight_all_paths that depends only on w (the adding-method elements of
// every layer at w's Snell invariant, per channel), to evaluate many events towards one w.
struct ConnectionTarget {
  glm::dvec3 w{0.0, 0.0, 1.0};
  bool valid = false;
  double mu_out = 0.0;
  std::vector<double> mu;                       // cosine in each layer (< 0: cannot propagate)
  std::vector<double> t[kChannels];             // one-pass transmittance of each layer
  std::vector<double> t_out[kChannels];         // transmittance from layer k out towards w
  std::vector<double> r_above[kChannels];       // R back down from above layer k
  std::vector<double> r_below[kChannels];       // R back up from below layer k
};
ConnectionTarget prepare_connection(const LayerStack& stack, const glm::dvec3& w);
Spectrum connection_weight_all_paths(const LayerStack& stack, const ScatterEvent& event,
                                     const ConnectionTarget& target);

// The solid-angle density (outside measure, 1/sr) with which the walk itself leaves along w
// straight from `event` with no further interaction: phase (or cosine) sampling pdf of the inside
// direction, times the Jacobian d(omega_inside)/d(omega_outside) = (n_out/n_layer)^2 |mu_out|/|mu|,
// times the probability that the flight crosses to the boundary uncollided (in the walk's hero
// channel event.hero, the one it samples with), times the Fresnel transmission probabilities of
// the interfaces crossed. Conditional on the hero, this is the density of the walk's exits, the
// one a renderer needs to weight light samples against exits by MIS.
double connection_pdf(const LayerStack& stack, const ScatterEvent& event, const glm::dvec3& w,
                      double guiding = 0.0);

}  // namespace lamina
