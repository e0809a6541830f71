// The table mode's BRDF/BTDF table of a stack, estimated by THE random walk (materials/brdf/brdf_table,
// the same code as `lamina brdf --method monte-carlo`) or computed by adding-doubling
// (materials/adding_doubling/adding_doubling, `--method adding-doubling`) before rendering; renderer/surfaces/
// table_surface.h evaluates and samples it, renderer/layered/layered_tables.h holds a scene's.
//
// Layout: `nodes` incidence cosines from grazing to normal (table_node_cosine); per node the walk's bin averages
// (K bins uniform in |cos theta_o| per side, M bins uniform in the azimuth relative to the
// incidence; docs/contracts.md "lamina brdf"). The delta parts are not tabulated: they come from the
// analytic zeroth order at the exact incidence.
// Evaluation: linear interpolation in mu_i between the two nearest nodes (clamped at the ends),
// piecewise constant over the outgoing bins. Sampling: the same two nodes chosen with the
// interpolation weights, then a bin from that node's CDF (bins weighted by their power
// value * projected solid angle, averaged over channels), then a direction uniform in projected
// solid angle inside the bin; pdf = sum_j w_j P_j(bin) |cos| / Omega_proj(bin), consistent.
// Reciprocity: the table is indexed with the viewer direction as the incidence (as the walk).
#pragma once

#include <cstdint>
#include <vector>

#include "materials/adding_doubling/adding_doubling.h"
#include "materials/base/spectrum.h"
#include "materials/stack/stack.h"

namespace lamina {

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
  // How each node's bins are computed: adding-doubling (the default: brdf_tables_adding_doubling
  // at quadrature_points, all nodes in one solution, no noise, the delta-M forward peak in the
  // mirror / ballistic bin) or the walk (brdf_table_monte_carlo with walks_per_node and seed).
  // Adding-doubling raises the quadrature order from quadrature_points (in steps of 8, up to 48)
  // until the delta-M forward peak holds at most 3% of a scattering (delta_m_truncation; at 16
  // points g = 0.9 puts 19% in it and the bins beside the ballistic direction miss by ~10 sigma
  // of a 1e6-walk table), and falls back to the walk when that is not enough or a backward lobe
  // is not resolved (backward part > 1e-3, e.g. g < -0.8): LayeredTable::walk_fallback.
  enum class Method { MonteCarlo, AddingDoubling };
  Method method = Method::AddingDoubling;
  int quadrature_points = 16;
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
  // Method::AddingDoubling only: the order used, and whether the stack needed the walk instead.
  int quadrature_points = 0;
  bool walk_fallback = false;

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

// The adding-doubling settings with which bins of `stack` are computed (the table mode's rule,
// TableSettings::method): from `quadrature_points`, the order rises by 8 (to 48) until delta-M's
// forward peak holds at most 3% of a scattering. False if that is not enough, or a backward lobe
// is not resolved (backward part > 1e-3): such a stack needs the walk.
bool adding_doubling_resolves(const LayerStack& stack, int quadrature_points, AddingDoublingSettings* settings);

// Builds the table of `stack` by the walk or by adding-doubling (settings.method);
// deterministic for any thread count.
LayeredTable build_layered_table(const LayerStack& stack, const TableSettings& settings);

}  // namespace lamina
