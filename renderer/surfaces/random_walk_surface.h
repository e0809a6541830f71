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
#include "materials/walk/walk_options.h"
#include "renderer/surfaces/surface.h"

namespace lamina {

// The walk's options (materials/walk/walk_options.h: the walk, its light connections and the
// test hooks) with the renderer's preset, renderer_walk_options(), as the default.
struct RandomWalkOptions : WalkOptions {
  RandomWalkOptions() : WalkOptions(renderer_walk_options()) {}
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

  // The spectral mode's walk through a stack whose index varies with the wavelength (a leaf,
  // docs/spectral.md "Leaves: one wavelength through a leaf"): the stack is the path's wavelength
  // `channel` alone, and every estimate (light connections, per-event samples, the continuation)
  // is multiplied by `weight` in that channel and by 0 in the others.
  void follow_one_wavelength(int channel, double weight) {
    channel_weights_ = Spectrum(0.0);
    channel_weights_[channel] = weight;
    one_wavelength_ = true;
  }

 private:
  const LayerStack& stack_;
  int hero_;
  RandomWalkOptions options_;
  std::uint64_t* events_;
  // scatter() in every channel (follow_one_wavelength's factors not applied).
  bool scatter_all(const glm::dvec3& wo, Rng& rng, LightDirection* lights, int light_count, LightSampler* per_event,
                   SurfaceScatter* next) const;
  bool one_wavelength_ = false;
  Spectrum channel_weights_;  // follow_one_wavelength's factors
};

// The spectral mode at a path's first hit on a stack whose index varies with the wavelength (a
// leaf; docs/spectral.md, "Leaves: one wavelength through a leaf"): one walk per wavelength,
// walk c on stacks[c] (the stack at the path's wavelength c, grey), each giving its own channel's
// light connections and per-event light samples; the path continues along walk `follow`'s exit
// alone, weight 3 in that channel and 0 in the others. Unbiased per channel c: its connections
// are its own walk's, and the continuation that complements them (their MIS partner) counts
// with probability 1/3 times 3, `follow` being uniform on the channels and independent of the
// walks.
class WavelengthWalksSurface final : public Surface {
 public:
  WavelengthWalksSurface(const LayerStack* stacks, int follow, const RandomWalkOptions& options,
                         std::uint64_t* events = nullptr)
      : stacks_(stacks), follow_(follow), options_(options), events_(events) {}

  bool scatter(const glm::dvec3& wo, Rng& rng, LightDirection* lights, int light_count, LightSampler* per_event,
               SurfaceScatter* next) const override;
  bool draws_per_event() const override { return options_.per_event_pool_samples; }

 private:
  const LayerStack* stacks_;  // kChannels stacks
  int follow_;
  const RandomWalkOptions& options_;
  std::uint64_t* events_;
};

}  // namespace lamina
