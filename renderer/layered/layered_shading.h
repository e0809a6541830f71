// How the layered materials of a scene are shaded: the bindings, the mode (or one per material
// for --subsurface auto), the tables of the table mode and the walk's options. Shading
// (renderer/layered/shading.h) reads it to build the surface at each hit.
#pragma once

#include <memory>
#include <vector>

#include "materials/stack/spectral_stack.h"
#include "renderer/layered/layered_material.h"
#include "renderer/layered/subsurface_mode.h"
#include "renderer/surfaces/random_walk_surface.h"

namespace lamina {

class LayeredTables;
class SpectralTables;

// Switches for tests and noise measurements only; production leaves them as they are.
struct ShadingTestHooks {
  // random-walk mode: the hero channel of each walk stratified over the samples of a pixel
  // (renderer/layered/hero_strata.h; hero_strata.cpp has the derivation). false: every walk
  // draws its hero independently (the library's default), to measure what stratifying gains.
  bool stratified_hero = true;
  // The spectral mode: every layered material is walked as a leaf is (its index varying with the
  // wavelength; docs/spectral.md, "Leaves: one wavelength through a leaf"), to test that
  // estimator on stacks whose three-wavelength walk is its reference, and to measure its noise.
  bool one_wavelength_walks = false;
};

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
  const LayeredTables* tables = nullptr;  // SubsurfaceMode::Table
  // random-walk mode: how the walk connects to the lights and which approximations or guiding
  // it uses (`--pool-samples`, `--similarity-after`, `--guiding`; the naive and connections-only
  // estimators of the tests), as renderer/surfaces/random_walk_surface.h defines them.
  RandomWalkOptions walk;
  // The spectral mode: per glTF material slot, its file's chromophore and leaf layers (null: none),
  // evaluated at each path's wavelengths (renderer/layered/wavelength_stack.h).
  std::vector<std::shared_ptr<const SpectralStack>> spectral;
  const SpectralStack* spectral_for(int material) const {
    return material >= 0 && material < static_cast<int>(spectral.size()) ? spectral[material].get() : nullptr;
  }
  // The spectral mode's tables and Lambert albedos on a wavelength grid (table and lambert
  // modes; renderer/layered/spectral_tables.h).
  const SpectralTables* spectral_tables = nullptr;
  ShadingTestHooks test_hooks;
};

}  // namespace lamina
