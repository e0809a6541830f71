#include "materials/tables/layered_table.h"

#include <algorithm>
#include <chrono>
#include <cmath>

#include "materials/adding_doubling/adding_doubling.h"
#include "materials/brdf/brdf_table.h"
#include "materials/base/sampling.h"

namespace lamina {

double LayeredTable::projected_solid_angle(int k) const {
  // int |cos| dw over |cos| in [lo, hi], dphi: (hi^2 - lo^2)/2 * dphi.
  const double lo = static_cast<double>(k) / settings.bins_theta, hi = (k + 1.0) / settings.bins_theta;
  return 0.5 * (hi - lo) * (hi + lo) * (2.0 * kPi / settings.bins_phi);
}

double table_node_cosine(const TableSettings& settings, int j) {
  if (settings.nodes < 2) return 1.0;
  return settings.grazing_cosine + (1.0 - settings.grazing_cosine) * j / (settings.nodes - 1.0);
}

TableNodes table_nodes_at(const TableSettings& settings, double mu) {
  TableNodes t;
  const int n = settings.nodes;
  if (n < 2) return t;
  // Linear interpolation in mu between evenly spaced nodes, clamped at both ends.
  const double x = std::clamp((mu - settings.grazing_cosine) / (1.0 - settings.grazing_cosine) * (n - 1), 0.0, n - 1.0);
  t.node[0] = std::min(static_cast<int>(x), n - 1);
  t.node[1] = std::min(t.node[0] + 1, n - 1);
  t.weight[1] = x - t.node[0];
  t.weight[0] = 1.0 - t.weight[1];
  return t;
}

bool adding_doubling_resolves(const LayerStack& stack, int quadrature_points, AddingDoublingSettings* ad) {
  ad->quadrature_points = quadrature_points;
  DeltaMTruncation truncation = delta_m_truncation(stack, *ad);
  while (truncation.forward > 0.03 && ad->quadrature_points < 48) {
    ad->quadrature_points = std::min(48, ad->quadrature_points + 8);
    truncation = delta_m_truncation(stack, *ad);
  }
  return truncation.forward <= 0.03 && truncation.backward <= 1e-3;
}

LayeredTable build_layered_table(const LayerStack& stack, const TableSettings& settings) {
  const auto start = std::chrono::steady_clock::now();
  LayeredTable t;
  t.stack = &stack;
  t.settings = settings;
  const int B = t.bins();
  t.value.resize(static_cast<std::size_t>(settings.nodes) * B);
  t.cdf.resize(static_cast<std::size_t>(settings.nodes) * B);
  t.power.resize(settings.nodes);
  // Adding-doubling solves every node at once (one solution, an incidence node per table node).
  std::vector<BrdfTable> ad_tables;
  AddingDoublingSettings ad;
  ad.quadrature_points = settings.quadrature_points;
  ad.single_scattering_bins = false;
  // Energy-conserving rough interfaces: the bins hold all that the surface does not add exactly.
  ad.bins_hold_unscattered = true;
  if (settings.method == TableSettings::Method::AddingDoubling) {
    t.walk_fallback = !adding_doubling_resolves(stack, settings.quadrature_points, &ad);
    t.quadrature_points = ad.quadrature_points;
  }
  if (settings.method == TableSettings::Method::AddingDoubling && !t.walk_fallback) {
    BrdfOptions o;
    o.bins_theta = settings.bins_theta;
    o.bins_phi = settings.bins_phi;
    std::vector<double> theta(settings.nodes);
    for (int j = 0; j < settings.nodes; ++j) theta[j] = std::acos(table_node_cosine(settings, j)) * 180.0 / kPi;
    ad_tables = brdf_tables_adding_doubling(stack, o, theta, ad);
  }
  for (int j = 0; j < settings.nodes; ++j) {
    BrdfOptions o;
    const double mu = table_node_cosine(settings, j);
    o.theta_i_deg = std::acos(mu) * 180.0 / kPi;
    o.samples = settings.walks_per_node;
    o.bins_theta = settings.bins_theta;
    o.bins_phi = settings.bins_phi;
    o.seed = settings.seed + 1000003ull * j;
    const BrdfTable bt = ad_tables.empty() ? brdf_table_monte_carlo(stack, o) : std::move(ad_tables[j]);
    double sum = 0.0;
    for (int side = 0; side < 2; ++side)
      for (int k = 0; k < settings.bins_theta; ++k)
        for (int m = 0; m < settings.bins_phi; ++m) {
          const int b = bt.bin_index(static_cast<BrdfSide>(side), k, m);
          const Spectrum v = bt.value[b];
          t.value[static_cast<std::size_t>(j) * B + b] = v;
          sum += std::max(0.0, v.average()) * t.projected_solid_angle(k);
          t.cdf[static_cast<std::size_t>(j) * B + b] = sum;
        }
    t.power[j] = sum;
    for (int b = 0; b < B; ++b) t.cdf[static_cast<std::size_t>(j) * B + b] = sum > 0.0 ? t.cdf[static_cast<std::size_t>(j) * B + b] / sum : 0.0;
  }
  t.build_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return t;
}

}  // namespace lamina
