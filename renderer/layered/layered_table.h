// table mode: a BRDF/BTDF table per layered material, estimated by THE random walk
// (materials/brdf_table, the same code as `lamina brdf --method monte-carlo`) before rendering.
//
// Layout: `nodes` incidence cosines mu_j = (j + 0.5) / nodes; per node the walk's bin averages
// (K bins uniform in |cos theta_o| per side, M bins uniform in the azimuth relative to the
// incidence; contracts.md "lamina brdf"). The delta parts are not tabulated: they come from the
// analytic zeroth order at the exact incidence.
// Evaluation: linear interpolation in mu_i between the two nearest nodes (clamped at the ends),
// piecewise constant over the outgoing bins. Sampling: the same two nodes chosen with the
// interpolation weights, then a bin from that node's CDF (bins weighted by their power
// value * projected solid angle, averaged over channels), then a direction uniform in projected
// solid angle inside the bin; pdf = sum_j w_j P_j(bin) |cos| / Omega_proj(bin), consistent.
// Reciprocity: the table is indexed with the viewer direction as the incidence (as the walk).
#pragma once

#include <map>
#include <memory>
#include <vector>

#include "materials/spectrum.h"
#include "materials/stack.h"
#include "renderer/layered/layered_material.h"
#include "renderer/surfaces/layered_surface.h"
#include "renderer/surfaces/surface.h"

namespace lamina {

class WalkCache;

struct TableSettings {
  // Incidence cosines, from grazing to normal (table_node_cosine). The end nodes sit at the ends
  // of the range so that grazing views are interpolated, not clamped: through a Fresnel
  // interface the diffuse part falls to 0 as the view grazes (T(mu) ~ mu), and a first node at
  // mu = 1/16 held it at its 86-degree value.
  int nodes = 9;
  double grazing_cosine = 0.002;  // the first node: 89.9 degrees
  int bins_theta = 12;   // K
  int bins_phi = 24;     // M
  std::uint64_t walks_per_node = 50000;
  std::uint64_t seed = 7;
};

struct LayeredTable {
  const LayerStack* stack = nullptr;  // the stack tabulated (for the zeroth order)
  TableSettings settings;
  // [node][side][k][m] per channel: the BRDF/BTDF bin average f(wo -> w), 1/sr.
  std::vector<Spectrum> value;
  // [node][bin over both sides]: CDF of the power per bin (channel mean), last entry = 1;
  // power[node] is the node's total diffuse power (0: nothing to sample).
  std::vector<double> cdf;
  std::vector<double> power;
  double build_seconds = 0.0;

  int bins() const { return 2 * settings.bins_theta * settings.bins_phi; }
  const Spectrum& at(int node, int bin) const { return value[static_cast<std::size_t>(node) * bins() + bin]; }
  double projected_solid_angle(int k) const;
};

// Node j's incidence cosine: grazing_cosine + (1 - grazing_cosine) j / (nodes - 1), evenly spaced
// (so a second difference over three nodes estimates the interpolation error: subsurface_auto).
double table_node_cosine(const TableSettings& settings, int j);
// Where cosine mu falls between the nodes: node[0] <= node[1] = node[0] + 1 (or both the end
// node outside the range), with linear interpolation weights weight[0] + weight[1] = 1.
struct TableNodes {
  int node[2] = {0, 0};
  double weight[2] = {1.0, 0.0};
};
TableNodes table_nodes_at(const TableSettings& settings, double mu);

// Builds the table of `stack` by the walk; deterministic for any thread count.
LayeredTable build_layered_table(const LayerStack& stack, const TableSettings& settings);

// Tables of every layered material of a scene (and of its flipped stack if it transmits).
class LayeredTables {
 public:
  LayeredTables(const LayeredBindings& bindings, const TableSettings& settings);
  // Only the materials whose slot in `only` is true (`--subsurface auto`: those that chose table).
  // With a cache (renderer/layered/walk_cache.h), tables found there are loaded instead of built, and
  // the ones built are stored.
  LayeredTables(const LayeredBindings& bindings, const TableSettings& settings, const std::vector<bool>& only,
                const WalkCache* cache = nullptr);
  const LayeredTable& get(const LayeredMaterial* m, bool from_below) const;
  double build_seconds() const { return seconds_; }  // of the tables built (not loaded)
  int built() const { return built_; }
  int loaded() const { return loaded_; }
  std::size_t bytes() const;

 private:
  std::map<std::pair<const LayeredMaterial*, bool>, std::unique_ptr<LayeredTable>> tables_;
  double seconds_ = 0.0;
  int built_ = 0, loaded_ = 0;
};

class TableSurface final : public Surface {
 public:
  TableSurface(const LayeredTable& table, const glm::dvec3& wo);
  Spectrum eval(const glm::dvec3& wo, const glm::dvec3& wi) const override;
  bool sample(const glm::dvec3& wo, glm::dvec2 u, BsdfSample* s) const override;
  double pdf(const glm::dvec3& wo, const glm::dvec3& wi) const override;

 private:
  int bin_of(const glm::dvec3& wo, const glm::dvec3& wi) const;
  const LayeredTable& table_;
  ZerothOrderLobes lobes_;
  int node_[2] = {0, 0};
  double weight_[2] = {1.0, 0.0};
};

}  // namespace lamina
