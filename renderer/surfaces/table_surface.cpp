#include "renderer/surfaces/table_surface.h"

#include <algorithm>
#include <cmath>

#include "materials/brdf/brdf_table.h"
#include "materials/base/sampling.h"
#include "materials/walk/random_walk.h"  // top_interface

namespace lamina {

TableSurface::TableSurface(const LayeredTable& table, const glm::dvec3& wo) : TableSurface(table, *table.stack, wo, nullptr, 0) {}

TableSurface::TableSurface(const LayeredTable& table, const LayerStack& hit_stack, const glm::dvec3& wo,
                           const TableFactor* factors, int factor_count, const SpectralTableChannels* spectral)
    : table_(table), factors_(factors), factor_count_(factor_count), spectral_(spectral), lobes_(hit_stack, wo) {
  if (hit_stack.rough_top()) {
    // No mirror delta: the smooth top's reflectance becomes the glossy lobe's sampling share.
    glossy_ = true;
    top_ = top_interface(hit_stack);
    p_glossy_ = lobes_.p_specular;
    lobes_.p_specular = 0.0;
    lobes_.p_diffuse = std::max(0.0, 1.0 - lobes_.p_ballistic);
    lobes_.zeroth.R_specular = Spectrum(0.0);
  }
  if (hit_stack.energy_conserving_rough() || hit_stack.any_diffuse_interface()) {
    // Only the unscattered light that meets no rough or diffuse interface is a delta (the table
    // holds the rest: materials/adding_doubling/adding_doubling.h, zeroth_order_above_rough).
    lobes_.zeroth.R_specular = glossy_ ? Spectrum(0.0) : zeroth_order_above_rough(hit_stack, std::clamp(wo.z, 0.0, 1.0)).R_specular;
    lobes_.zeroth.T_ballistic = Spectrum(0.0);
    lobes_.p_specular = std::clamp(lobes_.zeroth.R_specular.average(), 0.0, 1.0);
    lobes_.p_ballistic = 0.0;
    lobes_.p_diffuse = 1.0 - lobes_.p_specular;
  }
  const TableNodes at = table_nodes_at(table.settings, wo.z);
  for (int i = 0; i < 2; ++i) {
    node_[i] = at.node[i];
    weight_[i] = at.weight[i];
  }
}

Spectrum table_model_value(const LayeredTable& base_table, const TableFactor* factors, int factor_count, int node, int bin) {
  Spectrum f = base_table.at(node, bin);
  const Spectrum& base = base_table.at(node, bin);
  // A bin that T_0 leaves (nearly) empty, below 1e-12 times the node's diffuse power, keeps T_0;
  // one that a node table leaves empty is interpolated linearly (layered_tables.h).
  const double floor = 1e-12 * base_table.power[node] + 1e-300;
  for (int k = 0; k < factor_count; ++k) {
    const TableFactor& a = factors[k];
    const Spectrum& lo = a.lo->at(node, bin);
    const Spectrum& hi = a.hi->at(node, bin);
    for (int c = 0; c < kChannels; ++c) {
      if (!(base[c] > floor)) continue;
      double lo2 = 0.0, hi2 = 0.0;
      if (a.lo2) lo2 = a.lo2->at(node, bin)[c], hi2 = a.hi2->at(node, bin)[c];
      const bool positive = lo[c] > floor && hi[c] > floor && (!a.lo2 || (lo2 > floor && hi2 > floor));
      if (positive) {  // T_a(x) / T_0 = exp of the (bi)linear interpolation of ln(T / T_0)
        double l = (1.0 - a.t) * std::log(lo[c] / base[c]) + a.t * std::log(hi[c] / base[c]);
        if (a.lo2) l = (1.0 - a.t2) * l + a.t2 * ((1.0 - a.t) * std::log(lo2 / base[c]) + a.t * std::log(hi2 / base[c]));
        f[c] *= std::exp(l);
      } else {
        double x = (1.0 - a.t) * lo[c] + a.t * hi[c];
        if (a.lo2) x = (1.0 - a.t2) * x + a.t2 * ((1.0 - a.t) * lo2 + a.t * hi2);
        f[c] *= x / base[c];
      }
    }
  }
  return f;
}

Spectrum TableSurface::value(int node, int bin) const {
  if (!spectral_) return table_model_value(table_, factors_, factor_count_, node, bin);
  return spectral_table_value(*spectral_, table_, factors_, factor_count_, node, bin);
}

Spectrum spectral_table_value(const SpectralTableChannels& s, const LayeredTable& base_table, const TableFactor* factors,
                              int factor_count, int node, int bin) {
  Spectrum f;
  for (int c = 0; c < kChannels; ++c)
    for (int k = 0; k < 2; ++k)
      if (s.weight[c][k] != 0.0) f[c] += s.weight[c][k] * s.table[c][k]->at(node, bin)[s.channel[c][k]];
  if (factor_count == 0) return f;
  // The factors' product T / T_0 in RGB, uplifted as an RGB coefficient is (grey stays grey).
  return f * s.wavelengths->ratio(table_model_value(base_table, factors, factor_count, node, bin), base_table.at(node, bin));
}

int TableSurface::bin_of(const glm::dvec3& wo, const glm::dvec3& wi) const {
  // As materials/brdf/brdf_table: |cos| bins, azimuth_bin from the incidence's azimuth (here the viewer's).
  const int K = table_.settings.bins_theta, M = table_.settings.bins_phi;
  const int side = wi.z > 0.0 ? 0 : 1;
  const int k = std::clamp(static_cast<int>(std::abs(wi.z) * K), 0, K - 1);
  return (side * K + k) * M + azimuth_bin(wi.x, wi.y, std::atan2(wo.y, wo.x), M);
}

Spectrum TableSurface::eval(const glm::dvec3& wo, const glm::dvec3& wi) const {
  if (wo.z <= 0.0 || wi.z == 0.0 || (wi.z < 0.0 && !lobes_.transmits)) return Spectrum(0.0);
  const int b = bin_of(wo, wi);
  Spectrum f = value(node_[0], b) * weight_[0] + value(node_[1], b) * weight_[1];
  // Reciprocity (materials/walk/walk_estimator.h): the table holds f(wo -> wi).
  if (wi.z < 0.0) f *= lobes_.t_factor;
  if (glossy_ && wi.z > 0.0) f += Spectrum(top_.eval(wo, wi));
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
  const double table_pdf = lobes_.p_diffuse * p * std::abs(wi.z) / table_.projected_solid_angle(k);
  if (!glossy_) return table_pdf;
  const double glossy_pdf = wi.z > 0.0 ? reflection_pdf(top_.distribution, wo, wi) : 0.0;
  return p_glossy_ * glossy_pdf + (1.0 - p_glossy_) * table_pdf;
}

bool TableSurface::sample(const glm::dvec3& wo, glm::dvec2 u, BsdfSample* s) const {
  if (wo.z <= 0.0) return false;
  if (glossy_) {
    // The glossy lobe with probability p_glossy_ (u.x reused in both branches).
    if (u.x < p_glossy_) {
      glm::dvec3 wi;
      double weight;
      if (!top_.sample_reflection(wo, {u.x / p_glossy_, u.y}, &wi, &weight)) return false;
      return complete_sample(*this, wo, wi, s);
    }
    u.x = std::min((u.x - p_glossy_) / (1.0 - p_glossy_), 1.0 - 1e-16);
  }
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
