// The random walk's options: one struct for the walk itself (materials/walk/random_walk.h, driven
// by `lamina brdf`, the tables and the albedos) and for the renderer's random-walk surface,
// which adds how its events connect to the lights. Every value but the similarity option keeps
// the estimators unbiased: they trade variance for time. The library's defaults are the
// member initialisers; the renderer's are renderer_walk_options() (a cheaper roulette), and the
// user-facing ones have a row in renderer/render/walk_option_table.h (flag, EXR key, help).
#pragma once

namespace lamina {

struct LayerStack;

struct WalkOptions {
  // ---- The walk (random_walk.h) ----

  // Russian roulette once the largest channel of the weight is below this fraction of the
  // weight the walk entered with (1 - R(wi)), at scattering events, with survival
  // `roulette_survival`. The renderer uses 0.5 and 0.5 (renderer_walk_options): once every
  // channel of a walk's weight has fallen below half of what entered, each further scattering
  // event lets it survive with probability 1/2 (weight doubled). Survival equal to the threshold
  // keeps every survivor's weight below the entering weight: no fireflies. Against 0.01 and 0.1
  // it halves a skin walk's events for a few per cent more variance (`walk_variance`: events x
  // relative variance 214.6 -> 142 on skin_oily, 29.5 -> 16 on the back-lit leaf;
  // docs/layered_rendering.md, "The walk's Russian roulette in the renderer").
  double roulette_threshold = 0.01;
  double roulette_survival = 0.1;
  // Guaranteed termination, unbiased, for walks that would not end by themselves (albedo 1 in a
  // semi-infinite layer, light bouncing between a white substrate and a TIR top). After
  // `forced_after` interactions (scatterings and interface events) every further interaction t
  // applies roulette regardless of weight with survival sqrt((t-1)/t), so that the walk is still
  // alive at t with probability s(t) = sqrt(forced_after / t) and then carries weight 1/s(t).
  // Why this schedule: in a conservative half-space the number of events before escape has the
  // tail P(T > t) ~ t^(-1/2); the second moment of the weight, sum_t t^(-3/2) / s(t), and the
  // expected length, sum_t t^(-1/2) s(t), are then both only logarithmic in the longest walk,
  // whereas a constant survival < 1 would give weights growing exponentially (infinite
  // variance) and no roulette an infinite expected length. Past `forced_exponential_after`
  // interactions the survival becomes the constant `forced_survival`, bounding the expected
  // length for any stack.
  int forced_after = 1000;
  int forced_exponential_after = 1000000;
  double forced_survival = 0.99;
  // APPROXIMATE, off by default (`--similarity-after N`): after `similarity_after` exact
  // collisions (-1: never; 0: from the entry, the whole walk) the walk continues in `similar`,
  // the stack's similarity transform (similarity_transform_into: g -> 0, sigma_s -> sigma_s
  // (1 - g)), which needs about 1/(1 - g) times fewer events. The switch falls between the
  // similarity_after-th event's collision and its scattering: that event and the ones after it
  // have ScatterEvent::similar set, scatter and fly in `similar`, and connect through it, not the
  // stack. The result is biased (the renderer measures and prints how much:
  // docs/layered_rendering.md). The renderer builds `similar` per hit (the stack may vary over
  // the surface).
  int similarity_after = -1;
  const LayerStack* similar = nullptr;
  // Guided walks (0: off, the default; `--guiding Q`): every flight that starts at a volume
  // scattering event in a layer that scatters isotropically (every lobe g = 0: after
  // --similarity-after 0, or isotropic stacks; an exact skin stack has none; elsewhere the walk
  // is classic, bit for bit) samples its direction and distance, with this probability, from
  // Dwivedi's zero-variance-based guided technique towards the top (materials/phase/dwivedi.h),
  // else classically; the weights are those of the mixture (one-sample MIS, balance heuristic,
  // per channel as the spectral MIS already is), so the walk stays unbiased. Exits and connection
  // pdfs account for it (connection_pdf, prepare_exit with the same guiding). It wins for long
  // walks in bright isotropic media and loses where walks are already short (docs/random_walk.md).
  double guiding = 0.0;
  // Tally WalkResult::absorbed (energy-balance checks, `lamina brdf`'s direct absorbed estimate).
  // The renderer does not read it and skips its share of every collision's weighting.
  bool tally_absorbed = true;
  // Fill WalkResult::exit_pdf. It costs a prepared exit (the refracted direction in every layer)
  // per walk, and neither the renderer (which needs the mean over heroes, exit_pdf_for_mis) nor
  // `lamina brdf` reads it: on the MCML slab it was a tenth of a walk's time.
  bool compute_exit_pdf = false;

  // ---- The renderer's light connections (renderer/surfaces/random_walk_surface.h) ----

  // Connect every event to a fresh light sample of its own from the integrator's LightSampler
  // (the lights of the pool: environment and emissive triangles), as well as to the shared
  // directions. false (the default, `--pool-samples shared`): the pool's sample is shared by the
  // walk's events too.
  bool per_event_pool_samples = false;
  // Connection roulette (random_walk_surface.cpp): events whose way out is attenuated by more
  // than exp(-depth) in every channel are connected with probability exp(depth - bound). Tests
  // lower it to make the roulette matter.
  double connection_roulette_depth = 6.0;
  // Next-flight connections for delta lights (materials/walk/next_flight_connection.h, `--next-flight
  // off` to disable): each flight's direction by two techniques, the walk's phase sampling and
  // the phase function around the light's inside direction, combined by MIS. Unbiased; it
  // removes the spikes of forward-peaked connections.
  bool next_flight = true;
  // ... in layers whose HG g is at least this (the spikes grow with g; measured equal-error
  // speed-ups: skin, g 0.8, 1.4x; the leaf's mesophyll, g 0.5, 0.94x: docs/layered_rendering.md,
  // "Next-flight connections").
  double next_flight_min_g = 0.6;
  // Their roulette: a technique-B connection attenuated by more than exp(-depth) in every channel
  // (next_flight_depth_bound) is made with probability exp(depth - bound). 1 measured best on
  // head_skin (docs/layered_rendering.md, "Next-flight connections"): B's connections from below
  // one mean free path are small.
  double next_flight_roulette_depth = 1.0;
  // Connection roulette on the phase function (0: off): an event's connection to a delta light
  // through a layer with one HG lobe, whose phase function p towards the light's inside
  // direction is below this times the isotropic 1 / (4 pi), is made with probability
  // p / (this / (4 pi)) and weight 1 / that. Unbiased; through g = 0.8 most directions are far
  // below isotropic and bring little (docs/layered_rendering.md, "The connections' roulettes": at
  // 1, 4-7 % fewer render instructions for 1-3 % more variance on the skin scenes; 2 and 4 cost
  // more variance than they save).
  double connection_phase_roulette = 1.0;

  // ---- Test hooks: estimators for tests and measurements, never set by the renderer ----
  struct TestHooks {
    // The naive estimator of the seed's slides (tests and the bias report,
    // docs/layered_rendering.md, "The naive variant and its bias"): connections without the
    // Fresnel transmission of the way out and with weight 1, and exits that reach a light also
    // with weight 1 (no MIS: counted twice).
    bool naive = false;
    // Connections with weight 1 and the walk's straight exits ignored when they reach a light
    // (unbiased, no MIS), to show what MIS buys at g -> 1.
    bool connections_only = false;
  };
  TestHooks test_hooks;
};

// The renderer's preset: the library's defaults but the walk's roulette at 0.5 / 0.5 (see
// roulette_threshold) and no absorbed tally (the renderer does not read it).
inline WalkOptions renderer_walk_options() {
  WalkOptions o;
  o.roulette_threshold = 0.5;
  o.roulette_survival = 0.5;
  o.tally_absorbed = false;
  return o;
}


}  // namespace lamina
