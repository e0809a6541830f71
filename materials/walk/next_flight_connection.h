// Next-flight connections: the connection of a walk's events to a DELTA light direction with
// two techniques for the direction of each flight, combined by multiple importance sampling.
//
// Why. Towards a fixed outside direction w, an event with propagation direction d contributes
// W p(d . b) A (random_walk.h, connection_weight; b the inside direction that refracts out to w,
// A the attenuation of the way out). In a forward-scattering layer (skin: HG g = 0.8) p(d . b)
// varies by ((1 + g)/(1 - g))^3 = 729 over d, and d is whatever the previous event's phase
// sampling gave: a walk whose flight happens to point along b scores a spike. No MIS with the
// light helps (its direction is a delta); this is the largest term of a skin walk's variance
// (docs/layered_rendering.md, "Where a walk's variance comes from").
//
// What. Let event e-1 (volume, layer l, incoming direction a, depth z0, throughput W) start a
// flight. Its direction d has density p_A(d) = p(a . d) (the walk's phase sampling). The next
// event's expected connection, restricted to collisions in layer l before the flight meets an
// interface, is
//   C = integral over d of p_A(d) G(d),   G(d) = p(d . b) / mu_b  K  integral_0^s_max
//        sigma_s exp(-sigma_t s) exp(-r (D0 + k s)) ds
// (r = sigma_t / mu_b the exit's optical depth per mm of distance to the exit side, D0 the
// event's distance to it, k the change of that distance per unit path along d, s_max the path
// to the layer's boundary, K = radiance_scale exp(-tau_beyond), per channel). Two techniques
// estimate it: A, the walk's own next event (its usual connection, when its flight is such a
// collision), and B, a direction d_B drawn from p_B(d) = p(d . b) (the phase function around b)
// with the integral over s done in closed form. Balance heuristic over the direction:
//   A: usual connection of the real next event x  p_A / (p_A + p_B)   at its direction,
//   B: W  p_A p_B / (p_A + p_B)  G(d_B) / p(d_B . b)                at d_B.
// Both are bounded by min(p_A, p_B): the spike is gone, the sum stays unbiased (Veach's thesis
// 9.2; each technique's weight is a function of the direction alone because the phase function
// is grey: the same density for every hero channel). Technique B multiplies the event's
// throughput W, itself an unbiased estimate of the power arriving at the event whatever the
// hero's sampling (spectral MIS), by a quantity computed with its own random numbers: unbiased.
//
// Where. Only in layers where the walk samples directions by one grey HG lobe with sigma_s > 0
// in every channel and no guiding (next_flight_layer), for events of the exact stack or of the
// similar one alike (pass the event's stack). Elsewhere, events connect as usual.
#pragma once

#include <algorithm>
#include <limits>

#include "materials/walk/random_walk.h"
#include "materials/base/spectrum.h"
#include "materials/stack/stack.h"

namespace lamina {

// The layer of `exit` qualifies (see above): its phase is one grey HG lobe with g >= min_g, it
// scatters in every channel, its flights are not guided, and some inside direction reaches the
// exit. (The spikes grow with g: on skin-like layers the variance of a walk's connection falls
// 1.3x at g = 0.5, 1.6x at 0.7, 1.9x at 0.9, for about 1.3x the time; docs/layered_rendering.md.)
bool next_flight_layer(int layer, const ExitDirection& exit, double min_g = 0.0);

// p_A: the density with which the previous volume event's phase sampling gave `event` its
// direction (ScatterEvent::flight_from_previous, in a next_flight_layer of HG parameter g).
double next_flight_direction_pdf(const ScatterEvent& previous, const ScatterEvent& event, double g);

// Technique A's weight, the balance heuristic p_A / (p_A + p_B), p_B the event's phase function
// towards the exit's inside direction (connect_direct's DirectExit::phase).
inline double next_flight_weight(double p_a, double p_b) { return p_a + p_b > 0.0 ? p_a / (p_a + p_b) : 0.0; }

// The same from the event alone: p_A and p_B evaluated here.
double next_flight_weight_of_event(const ScatterEvent& previous, const ScatterEvent& event,
                                   const ExitDirection& exit);

// Technique B from a volume event in a next_flight_layer: the next flight's collision
// connection, per unit event throughput (multiply by event.throughput), for the uniforms u1, u2.
Spectrum next_flight_connection(const LayerStack& stack, const ScatterEvent& event,
                                const ExitDirection& exit, double u1, double u2);

// Both techniques for one event, without roulette (benchmarks and tests; the renderer applies
// its own roulettes to each): event.throughput times its weighted connection_weight towards the
// prepared direction, plus technique B from it. `previous`: the walk's event before `event`.
Spectrum next_flight_event_connection(const LayerStack& stack, const ScatterEvent& previous,
                                      const ScatterEvent& event, const ExitDirection& exit, double u1,
                                      double u2);

// A lower bound, over the channels, of the optical depth that attenuates every technique-B
// connection of the event (sigma_t D0 + tau_beyond: any flight to depth D from D0 travels at
// least D0 - D, and the exit path from D is at least D): exp(-bound) bounds it, for roulette.
// (Inline: the renderer asks it of every event for every delta light.)
inline double next_flight_depth_bound(const LayerStack& stack, const ScatterEvent& event, const ExitDirection& exit) {
  const ExitDirection::LayerExit& path = exit.layers[event.layer];
  const double distance0 = distance_to_exit_side(stack, event, exit);
  double bound = std::numeric_limits<double>::infinity();
  for (int c = 0; c < kChannels; ++c) bound = std::min(bound, path.sigma_t[c] * distance0 + path.tau_beyond[c]);
  return bound;
}

}  // namespace lamina
