#include "renderer/layered/spectral_tables.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <optional>
#include <stdexcept>

#include <tbb/parallel_for.h>

#include "materials/tables/albedo.h"
#include "renderer/layered/layered_tables.h"
#include "renderer/layered/stack_bindings.h"
#include "renderer/layered/walk_cache.h"
#include "renderer/layered/wavelength_stack.h"

namespace lamina {

double WavelengthTableGrid::nm(int j) const {
  return kSpectralFirstNm + (kSpectralLastNm - kSpectralFirstNm) * static_cast<double>(j) / (count - 1);
}

void WavelengthTableGrid::locate(double nm, int* j, double* t) const {
  const double x = std::clamp((nm - kSpectralFirstNm) / (kSpectralLastNm - kSpectralFirstNm), 0.0, 1.0) * (count - 1);
  *j = std::min(static_cast<int>(x), count - 2);
  *t = x - *j;
}

bool binds_chromophores(const LayeredMaterial& m) {
  const StackBindings* b = m.bindings();
  if (!b) return false;
  for (const StackParameter& p : b->parameters())
    if (p.kind == StackParameter::Kind::kChromophore) return true;
  return false;
}

LayerStack stack_at_grid(const LayerStack& stack, const SpectralStack* chromophores, bool from_below,
                         const WavelengthTableGrid& grid, int g) {
  const SampledWavelengths w = SampledWavelengths::at(grid.nm(3 * g), grid.nm(3 * g + 1), grid.nm(3 * g + 2));
  LayerStack out;
  stack_at_wavelengths(stack, chromophores, from_below, w, &out);
  return out;
}

SpectralTables::SpectralTables(const LayeredBindings& bindings,
                               const std::vector<std::shared_ptr<const SpectralStack>>& chromophores, const LayeredTables* rgb,
                               const std::vector<bool>& tables_for, const std::vector<bool>& albedos_for,
                               const TableSettings& settings, const WalkCache* cache, WavelengthTableGrid grid)
    : grid_(grid) {
  const auto t0 = std::chrono::steady_clock::now();
  const int groups = grid_.count / 3;
  auto chromophores_of = [&](std::size_t i) { return i < chromophores.size() ? chromophores[i].get() : nullptr; };
  // Every grid stack to tabulate, built in parallel (each table is deterministic, so the result
  // does not depend on the threads).
  std::vector<std::pair<GridTables*, int>> work;
  for (std::size_t i = 0; i < bindings.by_material.size(); ++i) {
    const LayeredMaterial* m = bindings.by_material[i].get();
    const bool table = i < tables_for.size() && tables_for[i], albedo = i < albedos_for.size() && albedos_for[i];
    if (!m || !(table || albedo)) continue;
    if (binds_chromophores(*m))
      throw std::runtime_error(m->source() + ": chromophore layers bound to maps are not tabulated per wavelength "
                                             "(render it with --subsurface random-walk or auto)");
    if (albedo && !albedos_.count(m)) {
      std::vector<double>& a = albedos_[m];
      a.resize(static_cast<std::size_t>(grid_.count));
      for (int g = 0; g < groups; ++g) {
        const Spectrum v = diffuse_bihemispherical_albedo_adding_doubling(stack_at_grid(m->base_stack(), chromophores_of(i), false, grid_, g));
        for (int c = 0; c < kChannels; ++c) a[3 * g + c] = v[c];
      }
    }
    if (!table) continue;
    for (const bool below : {false, true}) {
      if (below && !m->transmits()) continue;
      if (tables_.count({m, below})) continue;
      GridTables& side = tables_[{m, below}];
      // T_0's stack: the base point's (the material's own stack without texture-driven parameters).
      const LayerStack& base = *rgb->get(m, below).stack;
      for (int g = 0; g < groups; ++g) {
        side.stacks.push_back(std::make_unique<LayerStack>(stack_at_grid(base, chromophores_of(i), below, grid_, g)));
        side.tables.emplace_back();
        work.emplace_back(&side, g);
      }
    }
  }
  std::vector<char> loaded(work.size(), 0);
  tbb::parallel_for(std::size_t(0), work.size(), [&](std::size_t k) {
    auto [side, g] = work[k];
    const LayerStack& stack = *side->stacks[static_cast<std::size_t>(g)];
    std::optional<LayeredTable> t;
    if (cache) t = cache->load(stack, settings);
    loaded[k] = t.has_value();
    if (!t) t = build_layered_table(stack, settings);
    t->stack = &stack;
    side->tables[static_cast<std::size_t>(g)] = std::make_unique<LayeredTable>(std::move(*t));
  });
  for (std::size_t k = 0; k < work.size(); ++k) {
    const LayeredTable& t = *work[k].first->tables[static_cast<std::size_t>(work[k].second)];
    if (loaded[k]) {
      ++tables_loaded_;
    } else {
      ++tables_built_;
      if (cache) cache->store(*t.stack, t);
    }
  }
  seconds_ = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

void SpectralTables::channels(const LayeredMaterial* m, bool from_below, const SampledWavelengths& w,
                              SpectralTableChannels* out) const {
  const GridTables& side = tables_.at({m, from_below});
  for (int c = 0; c < kChannels; ++c) {
    int j = 0;
    double t = 0.0;
    grid_.locate(w.nm(c), &j, &t);
    for (int k = 0; k < 2; ++k) {
      out->table[c][k] = side.tables[static_cast<std::size_t>((j + k) / 3)].get();
      out->channel[c][k] = (j + k) % 3;
    }
    out->weight[c][0] = 1.0 - t;
    out->weight[c][1] = t;
  }
  out->wavelengths = &w;
}

Spectrum SpectralTables::lambert_albedo(const LayeredMaterial& m, glm::dvec2 uv, const SampledWavelengths& w) const {
  const std::vector<double>& a = albedos_.at(&m);
  Spectrum out;
  for (int c = 0; c < kChannels; ++c) {
    int j = 0;
    double t = 0.0;
    grid_.locate(w.nm(c), &j, &t);
    out[c] = (1.0 - t) * a[static_cast<std::size_t>(j)] + t * a[static_cast<std::size_t>(j) + 1];
  }
  if (!m.bindings()) return out;
  return out * w.ratio(m.lambert_albedo_at(uv), m.lambert_albedo());
}

}  // namespace lamina
