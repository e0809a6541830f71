// The table and lambert modes in the spectral mode (docs/spectral.md, "Tables and albedos on a
// wavelength grid"). A path carries three wavelengths (materials/spectral/sampled_wavelengths.h);
// its stack at those wavelengths is not known before rendering, so the tables and Lambert
// albedos are computed on a grid of wavelengths and interpolated linearly in wavelength to each
// path's three:
//
// - the grid: kSpectralTableNodes wavelengths evenly over 360-830 nm (kSpectralFirstNm ..
//   kSpectralLastNm), the range the paths sample;
// - at each grid wavelength, the stack the walk would see there (stack_at_wavelengths,
//   renderer/layered/wavelength_stack.h: chromophore layers evaluated at it, every RGB coefficient
//   uplifted), three grid wavelengths to a stack (Spectrum's three channels), so a table of the
//   table mode (build_layered_table: adding-doubling, or the walk where it cannot resolve a lobe)
//   and a Lambert albedo (adding-doubling) of that stack hold three grid wavelengths;
// - a path's wavelength lambda between grid nodes j and j + 1 takes (1 - t) X_j + t X_{j+1}.
//
// The grid's spacing is chosen from the measured interpolation error of the colour the film
// integrates (bench/spectral_table_grid, docs/spectral.md). Texture-driven parameters act as in
// the RGB mode's model (renderer/layered/layered_tables.h: T_0 times the factors of its axes),
// with the RGB factors' ratio to T_0 uplifted to the path's wavelengths (as every RGB coefficient
// is); T_0 itself is the grid's table of the base point's stack. Chromophore layers bound to maps
// are not tabulated per wavelength (a material with them is rendered by the walk: auto chooses
// it, the fixed modes refuse them).
#pragma once

#include <map>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "materials/spectral/sampled_wavelengths.h"
#include "materials/stack/spectral_stack.h"
#include "materials/tables/layered_table.h"
#include "renderer/layered/layered_material.h"
#include "renderer/surfaces/table_surface.h"

namespace lamina {

class LayeredTables;
class WalkCache;

// Grid nodes over 360-830 nm: 48 (a spacing of 10 nm), a multiple of 3 (three to a stack).
inline constexpr int kSpectralTableNodes = 48;

struct WavelengthTableGrid {
  int count = kSpectralTableNodes;
  double nm(int j) const;
  // The node j below `nm` (clamped to the grid) and the weight t of node j + 1.
  void locate(double nm, int* j, double* t) const;
};

// Whether the material binds a chromophore of its file to a map (such a layer is not tabulated
// per wavelength).
bool binds_chromophores(const LayeredMaterial& m);

class SpectralTables {
 public:
  // Tables of the materials whose slot in `tables_for` is true (T_0's stack from `rgb`, the RGB
  // tables, which give the factors and the sampling), Lambert albedos of those in `albedos_for`;
  // chromophores: per slot, the file's chromophore layers (null: none). With a cache, the grid
  // stacks' tables are loaded from it or stored in it like any table. Throws std::runtime_error,
  // one line naming the file, for a material that binds chromophores to maps.
  SpectralTables(const LayeredBindings& bindings, const std::vector<std::shared_ptr<const SpectralStack>>& chromophores,
                 const LayeredTables* rgb, const std::vector<bool>& tables_for, const std::vector<bool>& albedos_for,
                 const TableSettings& settings, const WalkCache* cache = nullptr, WavelengthTableGrid grid = {});
  // The grid tables and weights of each of the path's wavelengths (TableSurface's spectral model).
  void channels(const LayeredMaterial* m, bool from_below, const SampledWavelengths& w, SpectralTableChannels* out) const;
  // The lambert mode's albedo at a hit: the grid's albedos of the material's stack at the path's
  // wavelengths, times the RGB model's ratio for texture-driven parameters
  // (LayeredMaterial::lambert_albedo_at over lambert_albedo) uplifted to them.
  Spectrum lambert_albedo(const LayeredMaterial& m, glm::dvec2 uv, const SampledWavelengths& w) const;
  double seconds() const { return seconds_; }
  int tables() const { return tables_built_ + tables_loaded_; }
  int tables_loaded() const { return tables_loaded_; }
  const WavelengthTableGrid& grid() const { return grid_; }

 private:
  // One stack's grid: table g holds grid nodes 3g, 3g + 1, 3g + 2 in its channels.
  struct GridTables {
    std::vector<std::unique_ptr<LayerStack>> stacks;
    std::vector<std::unique_ptr<LayeredTable>> tables;
  };
  WavelengthTableGrid grid_;
  std::map<std::pair<const LayeredMaterial*, bool>, GridTables> tables_;
  std::map<const LayeredMaterial*, std::vector<double>> albedos_;  // per grid node
  double seconds_ = 0.0;
  int tables_built_ = 0, tables_loaded_ = 0;
};

// The stack at grid wavelengths nm(3g), nm(3g + 1), nm(3g + 2).
LayerStack stack_at_grid(const LayerStack& stack, const SpectralStack* chromophores, bool from_below,
                         const WavelengthTableGrid& grid, int g);

}  // namespace lamina
