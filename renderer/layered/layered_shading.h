// What the integrator needs to shade the layered materials of a scene: the bindings, the mode
// (or one per material for --subsurface auto) and the tables of the table mode.
#pragma once

#include <vector>

#include "renderer/layered/layered_material.h"
#include "renderer/layered/subsurface_mode.h"

namespace lamina {

class LayeredTables;

// How layered materials are shaded (renderer/surfaces/first_order_surface.h lists the modes).
struct LayeredShading {
  const LayeredBindings* bindings = nullptr;
  SubsurfaceMode mode = SubsurfaceMode::RandomWalk;
  // `--subsurface auto`: the mode of each glTF material slot (renderer/layered/subsurface_auto.h);
  // empty: `mode` for every material.
  std::vector<SubsurfaceMode> per_material;
  SubsurfaceMode mode_for(int material) const {
    return material >= 0 && material < static_cast<int>(per_material.size()) ? per_material[material] : mode;
  }
  // Tests and the bias report only: the naive random-walk estimator of the seed's slides. Light
  // samples at events without the Fresnel transmission of the way out and with weight 1, and
  // the walk's exits that reach a light also with weight 1 (no MIS: counted twice).
  bool naive = false;
  // Measurements only: light samples at events with weight 1 and the walk's straight exits
  // ignored when they reach a light (unbiased, no MIS), to show what MIS buys at g -> 1.
  bool connections_only = false;
  const LayeredTables* tables = nullptr;  // SubsurfaceMode::Table
  // random-walk mode: the hero channel of each walk stratified over the samples of a pixel
  // (HeroStrata below; integrator.cpp has the derivation). false: every walk draws its hero
  // independently (the library's default), kept for the tests and the noise measurements.
  bool stratified_hero = true;
  // random-walk mode: each event of a walk also connects to a light sample of its own from the
  // pool (environment, emissive triangles; renderer/surfaces/random_walk_surface.h), with its own
  // shadow ray (`--pool-samples per-event`). false (the default, `shared`): the walk's events
  // share one pool sample, as they always share the delta lights' directions.
  bool per_event_pool_samples = false;
  // random-walk mode, APPROXIMATE (-1: exact): the walk continues in the similarity-transformed
  // stack after this many events (`--similarity-after N`; RandomWalkOptions).
  int similarity_after = -1;
  // Tests only: RandomWalkOptions::connection_roulette_depth.
  double connection_roulette_depth = 6.0;
  // random-walk: RandomWalkOptions::guiding (`--guiding Q`, 0: off).
  double guiding = 0.0;
};

}  // namespace lamina
