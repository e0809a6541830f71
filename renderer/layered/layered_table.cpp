#include "renderer/layered/layered_table.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <optional>

#include "materials/brdf_table.h"
#include "materials/sampling.h"
#include "renderer/surfaces/layered_surface.h"
#include "renderer/layered/walk_cache.h"

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

LayeredTable build_layered_table(const LayerStack& stack, const TableSettings& settings) {
  const auto start = std::chrono::steady_clock::now();
  LayeredTable t;
  t.stack = &stack;
  t.settings = settings;
  const int B = t.bins();
  t.value.resize(static_cast<std::size_t>(settings.nodes) * B);
  t.cdf.resize(static_cast<std::size_t>(settings.nodes) * B);
  t.power.resize(settings.nodes);
  for (int j = 0; j < settings.nodes; ++j) {
    BrdfOptions o;
    const double mu = table_node_cosine(settings, j);
    o.theta_i_deg = std::acos(mu) * 180.0 / kPi;
    o.samples = settings.walks_per_node;
    o.bins_theta = settings.bins_theta;
    o.bins_phi = settings.bins_phi;
    o.seed = settings.seed + 1000003ull * j;
    const BrdfTable bt = brdf_table_monte_carlo(stack, o);
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

LayeredTables::LayeredTables(const LayeredBindings& bindings, const TableSettings& settings)
    : LayeredTables(bindings, settings, std::vector<bool>(bindings.by_material.size(), true)) {}

LayeredTables::LayeredTables(const LayeredBindings& bindings, const TableSettings& settings, const std::vector<bool>& only,
                             const WalkCache* cache) {
  // The table of `stack`: from the cache if it has it, else built (and stored).
  auto obtain = [&](const LayerStack& stack) {
    if (cache) {
      if (std::optional<LayeredTable> t = cache->load(stack, settings)) {
        ++loaded_;
        return std::make_unique<LayeredTable>(std::move(*t));
      }
    }
    auto t = std::make_unique<LayeredTable>(build_layered_table(stack, settings));
    seconds_ += t->build_seconds;
    ++built_;
    if (cache) cache->store(stack, *t);
    return t;
  };
  for (std::size_t i = 0; i < bindings.by_material.size(); ++i) {
    const auto& m = bindings.by_material[i];
    if (!m || i >= only.size() || !only[i] || tables_.count({m.get(), false})) continue;
    tables_[{m.get(), false}] = obtain(m->base_stack());
    if (m->transmits()) {
      tables_[{m.get(), true}] = obtain(m->flipped_stack());
    }
  }
}

const LayeredTable& LayeredTables::get(const LayeredMaterial* m, bool from_below) const {
  auto it = tables_.find({m, from_below && m->transmits()});
  return *it->second;
}

std::size_t LayeredTables::bytes() const {
  std::size_t n = 0;
  for (const auto& [k, t] : tables_) n += t->value.size() * sizeof(Spectrum) + t->cdf.size() * sizeof(double);
  return n;
}

TableSurface::TableSurface(const LayeredTable& table, const glm::dvec3& wo)
    : table_(table), lobes_(*table.stack, wo) {
  const TableNodes at = table_nodes_at(table.settings, wo.z);
  for (int i = 0; i < 2; ++i) {
    node_[i] = at.node[i];
    weight_[i] = at.weight[i];
  }
}

int TableSurface::bin_of(const glm::dvec3& wo, const glm::dvec3& wi) const {
  // As materials/brdf_table: |cos| bins, azimuth from the incidence's (here the viewer's).
  const int K = table_.settings.bins_theta, M = table_.settings.bins_phi;
  const int side = wi.z > 0.0 ? 0 : 1;
  const int k = std::clamp(static_cast<int>(std::abs(wi.z) * K), 0, K - 1);
  double phi = std::atan2(wi.y, wi.x) - std::atan2(wo.y, wo.x);
  phi -= 2.0 * kPi * std::floor(phi / (2.0 * kPi));
  const int m = std::clamp(static_cast<int>(phi / (2.0 * kPi) * M), 0, M - 1);
  return (side * K + k) * M + m;
}

Spectrum TableSurface::eval(const glm::dvec3& wo, const glm::dvec3& wi) const {
  if (wo.z <= 0.0 || wi.z == 0.0 || (wi.z < 0.0 && !lobes_.transmits)) return Spectrum(0.0);
  const int b = bin_of(wo, wi);
  Spectrum f = table_.at(node_[0], b) * weight_[0] + table_.at(node_[1], b) * weight_[1];
  // Reciprocity (layered_surface.h): the table holds f(wo -> wi).
  if (wi.z < 0.0) f *= lobes_.t_factor;
  return f;
}

double TableSurface::pdf(const glm::dvec3& wo, const glm::dvec3& wi) const {
  if (wo.z <= 0.0 || wi.z == 0.0 || (wi.z < 0.0 && !lobes_.transmits)) return 0.0;
  const int b = bin_of(wo, wi);
  const int B = table_.bins();
  const int k = (b / table_.settings.bins_phi) % table_.settings.bins_theta;
  double p = 0.0;
  for (int i = 0; i < 2; ++i) {
    const std::size_t base = static_cast<std::size_t>(node_[i]) * B;
    if (weight_[i] == 0.0 || table_.power[node_[i]] <= 0.0) continue;
    const double pb = table_.cdf[base + b] - (b > 0 ? table_.cdf[base + b - 1] : 0.0);
    p += weight_[i] * pb;
  }
  return lobes_.p_diffuse * p * std::abs(wi.z) / table_.projected_solid_angle(k);
}

bool TableSurface::sample(const glm::dvec3& wo, glm::dvec2 u, BsdfSample* s) const {
  if (wo.z <= 0.0) return false;
  if (lobes_.sample(wo, u.x, s)) return true;
  if (lobes_.p_diffuse <= 0.0) return false;
  double v = lobes_.diffuse_u(u.x);
  // Node by its interpolation weight (reusing v), then a bin by that node's CDF.
  int node = node_[0];
  if (v < weight_[0]) {
    v /= weight_[0];
  } else {
    node = node_[1];
    v = std::min((v - weight_[0]) / std::max(weight_[1], 1e-300), 1.0 - 1e-16);
  }
  if (table_.power[node] <= 0.0) return false;
  const int B = table_.bins();
  const double* cdf = &table_.cdf[static_cast<std::size_t>(node) * B];
  const int b = static_cast<int>(std::upper_bound(cdf, cdf + B, v) - cdf);
  if (b >= B) return false;
  const int K = table_.settings.bins_theta, M = table_.settings.bins_phi;
  const int side = b / (K * M), k = (b / M) % K, m = b % M;
  // Uniform in projected solid angle inside the bin: |cos|^2 uniform in [lo^2, hi^2] (since
  // |cos| d|cos| dphi = d(|cos|^2)/2 dphi) from u.y, phi uniform from the CDF inversion's
  // residual (uniform in [0, 1) given the bin).
  const double c0 = b > 0 ? cdf[b - 1] : 0.0;
  const double residual = std::clamp((v - c0) / std::max(cdf[b] - c0, 1e-300), 0.0, 1.0 - 1e-16);
  const double lo = static_cast<double>(k) / K, hi = (k + 1.0) / K;
  const double mu = std::sqrt(lo * lo + (hi * hi - lo * lo) * u.y);
  const double phi = std::atan2(wo.y, wo.x) + 2.0 * kPi * (m + residual) / M;
  const double st = std::sqrt(std::max(0.0, 1.0 - mu * mu));
  glm::dvec3 w{st * std::cos(phi), st * std::sin(phi), side == 0 ? mu : -mu};
  return complete_sample(*this, wo, w, s);
}

}  // namespace lamina
