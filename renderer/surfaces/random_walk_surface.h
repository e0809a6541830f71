// random-walk mode: the layered material as a stochastic surface. It cannot be evaluated, only
// estimated, so it is a Surface but not a Bsdf (renderer/surfaces/surface.h) and implements only
// Surface::scatter: one run of the materials/ random walk from the
// viewer's direction estimates both the connections to the integrator's light directions and
// the path's continuation (docs/layered_rendering.md derives the estimator and its MIS weights).
//
//  * The top interface's specular reflection is a delta lobe chosen with probability R(wo)
//    (weight R / R = 1; no light connection); otherwise the walk runs, chosen with probability
//    1 - R, and its weights, which carry (1 - R), are divided by it.
//  * Shared light connections: every scattering event e of the walk (throughput W_e) connects to
//    EVERY light direction wl the integrator drew at the shading point (the seed's "send a ray to
//    the light at each scattering event", one shadow ray per light sample instead of one per
//    event, as pbrt-v4's LayeredBxDF::f connects all events to one exit direction):
//        f_cos(wl) += W_e connection_weight(e, wl) [n factor] |cos theta_l| m_e(wl) / (1 - R),
//    m_e the power heuristic of the light's density against the walk leaving straight from e
//    along wl (exit_pdf_for_mis); 1 for a delta light. What depends only on wl (the refracted
//    direction in each layer, the Fresnel transmissions, the n^2 factors, the optical depth of
//    the layers crossed) is prepared once per light direction (materials/walk/random_walk.h,
//    ExitDirection); an event pays for its phase function and its own attenuation.
//    With a LightSampler (RandomWalkOptions::per_event_pool_samples, off by default), every event
//    also connects to a light sample of its own, with its own shadow ray: independent samples of
//    an environment or area light average over the light where a shared one cannot.
//  * Next-flight connections (delta lights, RandomWalkOptions::next_flight): in a layer with one
//    grey HG lobe, each event's connection to a delta light is split by MIS over the direction
//    of the flight that led to it: the event's own connection keeps the weight p_A / (p_A + p_B)
//    and the previous event adds the same expectation estimated along a direction drawn around
//    the light's inside direction (materials/walk/next_flight_connection.h).
//  * The continuation is the walk's exit, weight W_exit / (1 - R) [n factor]. An exit straight
//    from the last event competes with that event's light connection: MIS with pdf
//    exit_pdf_for_mis; any other exit (unscattered, or reflected inside since) cannot be found
//    by a light connection: delta (full weight).
// [n factor] is transmission_radiance_factor for directions on the far side (reciprocity,
// materials/walk/walk_estimator.h).
#pragma once

#include <cstdint>

#include "materials/stack/stack.h"
#include "renderer/surfaces/surface.h"

namespace lamina {

struct RandomWalkOptions {
  // Tests and the bias report only: the naive estimator of the seed's slides. Connections without
  // the Fresnel transmission of the way out and with weight 1, and exits that reach a light also
  // with weight 1 (no MIS: counted twice).
  bool naive = false;
  // Measurements only: connections with weight 1 and the walk's straight exits ignored when they
  // reach a light (unbiased, no MIS), to show what MIS buys at g -> 1.
  bool connections_only = false;
  // Connect every event to a fresh light sample of its own from the integrator's LightSampler
  // (the lights of the pool: environment and emissive triangles), as well as to the shared
  // directions. false (the default): the pool's sample is shared by the walk's events too.
  bool per_event_pool_samples = false;
  // APPROXIMATE (-1: exact, the default): after this many exact events (0: none) the walk
  // continues in the similarity-transformed stack (WalkSettings::similarity_after;
  // `--similarity-after N`).
  int similarity_after = -1;
  // Connection roulette (random_walk_surface.cpp): events whose way out is attenuated by more
  // than exp(-depth) in every channel are connected with probability exp(depth - bound). Tests
  // lower it to make the roulette matter.
  double connection_roulette_depth = 6.0;
  // Guided walks (WalkSettings::guiding, `--guiding Q`): the probability of Dwivedi's guided
  // technique for flights from isotropic layers (g = 0: after --similarity-after 0, or isotropic
  // stacks; an exact skin stack has none). Unbiased; off by default: it wins for long walks in
  // bright isotropic media and loses where walks are already short (docs/random_walk.md).
  double guiding = 0.0;
  // Next-flight connections for delta lights (materials/walk/next_flight_connection.h, `--next-flight
  // off` to disable): each flight's direction by two techniques, the walk's phase sampling and
  // the phase function around the light's inside direction, combined by MIS. Unbiased; it
  // removes the spikes of forward-peaked connections.
  bool next_flight = true;
  // ... in layers whose HG g is at least this (the spikes grow with g; measured equal-error
  // speed-ups: skin, g 0.8, 1.4x; the leaf's mesophyll, g 0.5, 0.94x: README, "Clean skin").
  double next_flight_min_g = 0.6;
  // Their roulette: a technique-B connection attenuated by more than exp(-depth) in every channel
  // (next_flight_depth_bound) is made with probability exp(depth - bound). 1 measured best on
  // head_skin (README, "Clean skin"): B's connections from below one mean free path are small.
  double next_flight_roulette_depth = 1.0;
  // Connection roulette on the phase function (0: off): an event's connection to a delta light
  // through a layer with one HG lobe, whose phase function p towards the light's inside
  // direction is below this times the isotropic 1 / (4 pi), is made with probability
  // p / (this / (4 pi)) and weight 1 / that. Unbiased; through g = 0.8 most directions are far
  // below isotropic and bring little (docs/layered_rendering.md, "The connections' roulettes": at
  // 1, 4-7 % fewer render instructions for 1-3 % more variance on the skin scenes; 2 and 4 cost
  // more variance than they save).
  double connection_phase_roulette = 1.0;
  // The walk's own Russian roulette (WalkSettings::roulette_threshold and roulette_survival):
  // once every channel of a walk's weight has fallen below half of what entered, each further
  // scattering event lets it survive with probability 1/2 (weight doubled). Survival equal to the
  // threshold keeps every survivor's weight below the entering weight: no fireflies. Unbiased;
  // against WalkSettings' 0.01 and 0.1 it halves a skin walk's events for a few per cent more
  // variance (`walk_variance`: events x relative variance 214.6 -> 142 on skin_oily, 29.5 -> 16
  // on the back-lit leaf; README, "Clean skin").
  double walk_roulette_threshold = 0.5;
  double walk_roulette_survival = 0.5;
};

class RandomWalkSurface final : public Surface {
 public:
  // stack: its top faces the viewer (wo.z > 0). hero: the walk's hero channel, or kRandomHero
  // (materials/walk/random_walk.h). events: if not null, counts the scattering events.
  RandomWalkSurface(const LayerStack& stack, int hero, const RandomWalkOptions& options,
                    std::uint64_t* events = nullptr)
      : stack_(stack), hero_(hero), options_(options), events_(events) {}

  bool scatter(const glm::dvec3& wo, Rng& rng, LightDirection* lights, int light_count, LightSampler* per_event,
               SurfaceScatter* next) const override;
  bool draws_per_event() const override { return options_.per_event_pool_samples; }

 private:
  const LayerStack& stack_;
  int hero_;
  RandomWalkOptions options_;
  std::uint64_t* events_;
};

}  // namespace lamina
