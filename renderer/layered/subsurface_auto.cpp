// The model choice of `--subsurface auto` (derivation of the metric in subsurface_auto.h).
#include "renderer/layered/subsurface_auto.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <limits>
#include <optional>
#include <sstream>

#include <nlohmann/json.hpp>

#include "materials/adding_doubling/adding_doubling.h"
#include "materials/brdf/brdf_table.h"
#include "materials/base/sampling.h"
#include "materials/tables/layered_table.h"
#include "renderer/layered/subsurface_mode.h"
#include "renderer/util/string_format.h"

namespace lamina {
namespace {

// Projected solid angle of bin k of a K x M grid (materials/brdf/brdf_table.h: bin k spans |cos| in
// [k/K, (k+1)/K]): int |cos| dw = (hi^2 - lo^2) / 2 * (2 pi / M).
double bin_projected_solid_angle(int k, int K, int M) {
  const double lo = static_cast<double>(k) / K, hi = (k + 1.0) / K;
  return 0.5 * (hi - lo) * (hi + lo) * (2.0 * kPi / M);
}

// One incidence's binned quantities, both sides: P(B) = value(B) Omega_proj(B) per channel.
struct Binned {
  std::vector<Spectrum> power, var;  // P(B) and its variance (0 for exact models)
  Spectrum R_specular{0.0}, T_ballistic{0.0};  // the delta parts (exact)
  Spectrum R_diffuse_var{0.0}, T_diffuse_var{0.0};  // variances of sum_B P over each side
  // The radiance factor of what the transmit side brings to a viewer on the top side under
  // equal radiance in both media: (n_above / n_below)^2 (radiance / n^2 is what crosses).
  double transmit_factor = 1.0;
  std::uint64_t walks = 0;

  // What a viewer on top sees in a uniform environment of radiance 1 in both media (per
  // channel): sum over the reflect side of P + R_specular + t (sum over the transmit side of P
  // + T_ballistic), and its variance (bounded by (sd_R + t sd_T)^2: the sides are correlated).
  Spectrum uniform_radiance() const {
    Spectrum r = R_specular, t = T_ballistic;
    const std::size_t half = power.size() / 2;
    for (std::size_t b = 0; b < power.size(); ++b) (b < half ? r : t) += power[b];
    return r + t * transmit_factor;
  }
  Spectrum uniform_variance() const {
    Spectrum v(0.0);
    for (int c = 0; c < kChannels; ++c) {
      const double sd = std::sqrt(R_diffuse_var[c]) + transmit_factor * std::sqrt(T_diffuse_var[c]);
      v[c] = sd * sd;
    }
    return v;
  }
};

double transmit_factor(const LayerStack& stack) {
  const double r = stack.above_ior / stack.below.ior;
  return stack.transmits() ? r * r : 1.0;
}

BrdfOptions options_at(double mu, const AutoSettings& s, std::uint64_t seed) {
  BrdfOptions o;
  o.theta_i_deg = std::acos(std::clamp(mu, 0.0, 1.0)) * 180.0 / kPi;
  o.bins_theta = s.bins_theta;
  o.bins_phi = s.bins_phi;
  o.seed = seed;
  return o;
}

// `table`'s bins as powers; `with_variance`: from its standard errors.
Binned binned(const BrdfTable& table, bool with_variance) {
  const int K = table.options.bins_theta, M = table.options.bins_phi;
  Binned out;
  out.power.resize(table.value.size());
  out.var.resize(table.value.size(), Spectrum(0.0));
  for (std::size_t b = 0; b < table.value.size(); ++b) {
    const double omega = bin_projected_solid_angle(static_cast<int>(b / M) % K, K, M);
    out.power[b] = table.value[b] * omega;
    if (with_variance) out.var[b] = table.stderr_[b] * table.stderr_[b] * (omega * omega);
  }
  out.R_specular = table.totals.R_specular.value;
  out.T_ballistic = table.totals.T_ballistic.value;
  if (with_variance) {
    out.R_diffuse_var = table.totals.R_diffuse.stderr_ * table.totals.R_diffuse.stderr_;
    out.T_diffuse_var = table.totals.T_diffuse.stderr_ * table.totals.T_diffuse.stderr_;
  }
  return out;
}

// `walks` more walks at this incidence (a new seed per round), pooled with the earlier ones:
// mean = (N1 m1 + N2 m2) / (N1 + N2), var = (N1^2 v1 + N2^2 v2) / (N1 + N2)^2.
void add_walks(const LayerStack& stack, BrdfOptions options, std::uint64_t walks, int round, Binned* pooled) {
  options.samples = walks;
  options.seed += 1000003u * static_cast<std::uint64_t>(round);
  Binned more = binned(brdf_table_monte_carlo(stack, options), true);
  more.transmit_factor = transmit_factor(stack);
  if (pooled->walks == 0) {
    *pooled = more;
    pooled->walks = walks;
    return;
  }
  const double n1 = static_cast<double>(pooled->walks), n2 = static_cast<double>(walks), n = n1 + n2;
  for (std::size_t b = 0; b < more.power.size(); ++b) {
    pooled->power[b] = (pooled->power[b] * n1 + more.power[b] * n2) * (1.0 / n);
    pooled->var[b] = (pooled->var[b] * (n1 * n1) + more.var[b] * (n2 * n2)) * (1.0 / (n * n));
  }
  pooled->R_diffuse_var = (pooled->R_diffuse_var * (n1 * n1) + more.R_diffuse_var * (n2 * n2)) * (1.0 / (n * n));
  pooled->T_diffuse_var = (pooled->T_diffuse_var * (n1 * n1) + more.T_diffuse_var * (n2 * n2)) * (1.0 / (n * n));
  pooled->walks += walks;
}

Binned first_order_binned(const LayerStack& stack, const BrdfOptions& options) {
  // The bins and the exact delta parts only: binned() does not read the first-order diffuse
  // totals, whose quadrature would cost as much as the bins.
  Binned out = binned(brdf_table_first_order(stack, options, 6, false), false);
  out.transmit_factor = transmit_factor(stack);
  return out;
}

// lambert: f = albedo / pi on the viewer's side only (layer below or not), no delta parts.
Binned lambert_binned(const Spectrum& albedo, const AutoSettings& s) {
  Binned out;
  const int K = s.bins_theta, M = s.bins_phi;
  out.power.assign(static_cast<std::size_t>(2 * K * M), Spectrum(0.0));
  out.var.assign(out.power.size(), Spectrum(0.0));
  for (int k = 0; k < K; ++k)
    for (int m = 0; m < M; ++m) out.power[static_cast<std::size_t>(k * M + m)] = albedo * (kInvPi * bin_projected_solid_angle(k, K, M));
  return out;
}

// A model minus the walk, as a linear combination sum_i c_i X_i of binned quantities (the same
// object may appear twice: its coefficients are merged first, so that shared noise cancels).
struct Difference {
  std::vector<Spectrum> d, d_var;  // per bin
  Spectrum du{0.0}, du_var{0.0};   // per channel: the uniform-light difference, its variance
};

Difference combine(std::vector<std::pair<const Binned*, double>> terms) {
  std::vector<std::pair<const Binned*, double>> merged;
  for (const auto& [x, c] : terms) {
    auto it = std::find_if(merged.begin(), merged.end(), [x = x](const auto& t) { return t.first == x; });
    if (it == merged.end()) merged.push_back({x, c});
    else it->second += c;
  }
  Difference out;
  const std::size_t n = terms.front().first->power.size();
  out.d.assign(n, Spectrum(0.0));
  out.d_var.assign(n, Spectrum(0.0));
  for (const auto& [x, c] : merged) {
    if (c == 0.0) continue;
    for (std::size_t b = 0; b < n; ++b) {
      out.d[b] += x->power[b] * c;
      out.d_var[b] += x->var[b] * (c * c);
    }
    out.du += x->uniform_radiance() * c;
    out.du_var += x->uniform_variance() * (c * c);
  }
  return out;
}

// The two relative errors of a difference against the walk at the same incidence, corrected
// for noise, and the noise scale of each (derivation in subsurface_auto.h).
struct Relative {
  double shape_num = 0.0, shape_var = 0.0;  // sum (P_m - P_hat)^2 - sigma^2, and sigma^2
  double shape_var2 = 0.0;                  // sum sigma^4 (the spread of shape_num: 2 sum sigma^4)
  double shape_cross = 0.0;                 // sum (P_m - P_hat)^2 sigma^2 (and 4 times it)
  double shape = 0.0, uniform = 0.0;
  double shape_noise = 0.0, uniform_noise = 0.0;  // sqrt(noise^2 / reference^2)
  double shape_ref2 = 0.0, uniform_ref2 = 0.0;     // the noise-corrected reference sums
};

// shape_ref2: the shape's reference sum, when it is not this incidence's own; 0 for its own.
Relative relative_to(const Difference& diff, const Binned& walk, double shape_ref2 = 0.0) {
  double d2 = 0.0, dvar = 0.0, dvar2 = 0.0, cross = 0.0, r2 = 0.0, rvar = 0.0;
  for (std::size_t b = 0; b < walk.power.size(); ++b)
    for (int c = 0; c < kChannels; ++c) {
      d2 += diff.d[b][c] * diff.d[b][c];
      dvar += diff.d_var[b][c];
      dvar2 += diff.d_var[b][c] * diff.d_var[b][c];
      cross += diff.d[b][c] * diff.d[b][c] * diff.d_var[b][c];
      r2 += walk.power[b][c] * walk.power[b][c];
      rvar += walk.var[b][c];
    }
  double u2 = 0.0, uvar = 0.0, ur2 = 0.0, urvar = 0.0;
  const Spectrum ref = walk.uniform_radiance(), ref_var = walk.uniform_variance();
  for (int c = 0; c < kChannels; ++c) {
    u2 += diff.du[c] * diff.du[c];
    uvar += diff.du_var[c];
    ur2 += ref[c] * ref[c];
    urvar += ref_var[c];
  }
  Relative r;
  r.shape_ref2 = shape_ref2 > 0.0 ? shape_ref2 : std::max(r2 - rvar, 1e-300);
  r.uniform_ref2 = std::max(ur2 - urvar, 1e-300);
  r.shape_num = d2 - dvar;
  r.shape_var = dvar;
  r.shape_var2 = dvar2;
  r.shape_cross = cross;
  r.shape = std::sqrt(std::max(d2 - dvar, 0.0) / r.shape_ref2);
  r.uniform = std::sqrt(std::max(u2 - uvar, 0.0) / r.uniform_ref2);
  r.shape_noise = std::sqrt(dvar / r.shape_ref2);
  r.uniform_noise = std::sqrt(uvar / r.uniform_ref2);
  // A stack that returns nothing diffusely (albedo 0, or no light enters) has no shape to get
  // wrong: its pixels are the delta parts, which the uniform error covers.
  if (r2 <= 0.0 && shape_ref2 <= 0.0) r.shape = r.shape_noise = r.shape_num = r.shape_var = 0.0;
  return r;
}

// The table's own statistical error, relative, for a table value interpolated as
// sum_i w_i X_i from nodes of `table_walks` walks each, from the prediction's walks at those
// nodes (`nodes[i]`, with their variances): per-bin variance scales as walks / table_walks, and
// the shape's relative error with sqrt(bin count ratio) (see subsurface_auto.h).
void add_table_statistics(const std::vector<std::pair<const Binned*, double>>& nodes, const AutoSettings& s,
                          const Relative& rel, double* shape2, double* uniform2) {
  // An adding-doubling table has no noise (its discretisation error, ~1e-4 of a bin, is far
  // below what the prediction resolves).
  if (s.table.method == TableSettings::Method::AddingDoubling) return;
  const double bins_ratio = static_cast<double>(s.table.bins_theta * s.table.bins_phi) / (s.bins_theta * s.bins_phi);
  for (const auto& [x, w] : nodes) {
    const double walks_ratio = static_cast<double>(x->walks) / static_cast<double>(std::max<std::uint64_t>(s.table.walks_per_node, 1));
    double v = 0.0, u = 0.0;
    for (const Spectrum& var : x->var) v += var.average() * kChannels;
    u = x->uniform_variance().average() * kChannels;
    *shape2 += w * w * v * walks_ratio * bins_ratio / rel.shape_ref2;
    *uniform2 += w * w * u * walks_ratio / rel.uniform_ref2;
  }
}

// The errors of the three models over a set of views: the uniform metric's worst view, and the
// shape metric's sums over views (its per-view estimate needs ~10^6 walks to resolve an error of
// a few percent over 2 x 6 x 12 bins and 3 channels; summed over the views it is an RMS over
// views and resolved with the walks the uniform metric needs).
struct Accumulator {
  ViewErrors worst;         // uniform: worst view; shape: filled in by finish()
  double shape_num[3] = {0.0, 0.0, 0.0}, shape_var2[3] = {0.0, 0.0, 0.0}, shape_cross[3] = {0.0, 0.0, 0.0};
  double table_stat_num = 0.0;  // the table's statistical part of the shape sum
  double shape_ref = 0.0;   // sum over views of the noise-corrected reference sums
};
constexpr double ModeErrors::*kModels[3] = {&ModeErrors::lambert, &ModeErrors::first_order, &ModeErrors::table};

void record(const Relative& r, int model, Accumulator* a) {
  ModeErrors& u = a->worst.uniform;
  u.*kModels[model] = std::max(u.*kModels[model], r.uniform);
  u.noise = std::max(u.noise, r.uniform_noise);
  a->shape_num[model] += r.shape_num;
  a->shape_var2[model] += r.shape_var2;
  a->shape_cross[model] += r.shape_cross;
}

// The table's errors given its interpolation bias (a Difference against the walk) and the nodes
// it interpolates: bias^2 + statistics^2 in each metric.
void record_table(const Difference& bias, const Binned& walk, const std::vector<std::pair<const Binned*, double>>& nodes,
                  const AutoSettings& s, double shape_ref2, Accumulator* a) {
  const Relative r = relative_to(bias, walk, shape_ref2);
  double shape2 = 0.0, uniform2 = 0.0;
  add_table_statistics(nodes, s, r, &shape2, &uniform2);
  ModeErrors& u = a->worst.uniform;
  u.table = std::max(u.table, std::sqrt(r.uniform * r.uniform + uniform2));
  u.table_noise = std::max(u.table_noise, std::sqrt(uniform2));
  u.noise = std::max(u.noise, r.uniform_noise);
  a->shape_num[2] += r.shape_num + shape2 * r.shape_ref2;
  a->shape_var2[2] += r.shape_var2;
  a->shape_cross[2] += r.shape_cross;
  a->table_stat_num += shape2 * r.shape_ref2;
}

// The shape metric from the sums: sqrt(max(sum num, 0) / sum ref). Its resolution: where the
// model equals the walk, each term of num is delta^2 - sigma^2 with delta ~ N(0, sigma^2), of
// variance 2 sigma^4, so the estimate of e^2 spreads by sqrt(2 sum sigma^4) / ref and e by the
// square root of that (for e > 0 the spread of e is smaller: ~ sd(e^2) / 2e).
//
// spread[m]: the standard deviation of model m's predicted error (the larger metric's), for the
// decision to stop adding walks. The shape's e^2 = num / ref spreads by
// sd2 = sqrt(2 sum sigma^4 + 4 sum delta^2 sigma^2) / ref (each term (delta + x)^2 - sigma^2 with
// x ~ N(0, sigma^2) has variance 2 sigma^4 + 4 delta^2 sigma^2; delta^2 estimated by the noisy
// difference, which overstates it), so e spreads by sd2 / 2e, at most sqrt(sd2) (near 0); the
// uniform error is a plain difference whose spread is its noise.
ViewErrors finish(const Accumulator& a, double* spread = nullptr) {
  ViewErrors e = a.worst;
  const double ref = std::max(a.shape_ref, 1e-300);
  for (int m = 0; m < 3; ++m) {
    const double shape = std::sqrt(std::max(a.shape_num[m], 0.0) / ref);
    e.shape.*kModels[m] = shape;
    e.shape.noise = std::max(e.shape.noise, std::sqrt(std::sqrt(2.0 * a.shape_var2[m]) / ref));
    if (spread) {
      const double sd2 = std::sqrt(2.0 * a.shape_var2[m] + 4.0 * a.shape_cross[m]) / ref;
      const double shape_spread = shape > 0.0 ? std::min(std::sqrt(sd2), sd2 / (2.0 * shape)) : std::sqrt(sd2);
      spread[m] = shape >= e.uniform.*kModels[m] ? shape_spread : e.uniform.noise;
    }
  }
  e.shape.table_noise = std::sqrt(a.table_stat_num / ref);
  return e;
}

const char* short_name(SubsurfaceMode m) { return subsurface_mode_name(m); }

// A prediction's reference, per side (i) and incidence (j).
using ReferenceGrid = std::vector<std::vector<Binned>>;

// The table's interpolation bias near incidence j of a row of n >= 3 incidences spaced `stride`
// table nodes apart: h^2 P'' / 8 at the midpoint between nodes (spacing h), with P'' from the
// second difference centred on an inner incidence (the end ones take their neighbour's),
// (P_{c-1} - 2 P_c + P_{c+1}) / (8 stride^2).
Difference interpolation_bias(const std::vector<Binned>& row, int j, int stride) {
  const int n = static_cast<int>(row.size());
  const int c = std::clamp(j, 1, n - 2);
  const double k = 1.0 / (8.0 * stride * stride);
  return combine({{&row[c - 1], k}, {&row[c], -2.0 * k}, {&row[c + 1], k}});
}

// The models' errors over the views (every side and incidence) against `reference`: lambert,
// first order (`first`, per view) and the table, whose interpolation error at view j comes from
// the reference's second difference over the incidences (spacing `stride` table nodes).
ViewErrors errors_against(const ReferenceGrid& reference, const ReferenceGrid& first, const Binned& lambert, int stride,
                          const AutoSettings& settings, double* spread) {
  Accumulator acc;
  for (std::size_t i = 0; i < reference.size(); ++i) {
    const int n = static_cast<int>(reference[i].size());
    for (int j = 0; j < n; ++j) {
      const Binned& walk = reference[i][j];
      const Relative rl = relative_to(combine({{&lambert, 1.0}, {&walk, -1.0}}), walk);
      acc.shape_ref += rl.shape_ref2;
      record(rl, 0, &acc);
      record(relative_to(combine({{&first[i][j], 1.0}, {&walk, -1.0}}), walk), 1, &acc);
      // The table's interpolation error (interpolation_bias). Its statistics: a half-half mix of
      // two nodes (the typical view between nodes).
      if (n >= 3) {
        record_table(interpolation_bias(reference[i], j, stride), walk, {{&walk, 0.5}, {&walk, 0.5}}, settings, 0.0, &acc);
      } else {
        record_table(combine({{&walk, 0.0}}), walk, {{&walk, 1.0}}, settings, 0.0, &acc);
      }
    }
  }
  return finish(acc, spread);
}

// The adding-doubling reference at `points` quadrature points (each side capped at its own full
// order, full[i]), every incidence of a side in one solution.
ReferenceGrid adding_doubling_reference(const std::vector<std::reference_wrapper<const LayerStack>>& stacks,
                                        const std::vector<AddingDoublingSettings>& full, int points,
                                        const std::vector<std::vector<BrdfOptions>>& options) {
  ReferenceGrid out(stacks.size());
  for (std::size_t i = 0; i < stacks.size(); ++i) {
    const int n = static_cast<int>(options[i].size());
    std::vector<double> theta(n);
    for (int j = 0; j < n; ++j) theta[j] = options[i][j].theta_i_deg;
    AddingDoublingSettings ad = full[i];
    ad.quadrature_points = std::min(points, full[i].quadrature_points);
    ad.single_scattering_bins = false;
    const std::vector<BrdfTable> tables = brdf_tables_adding_doubling(stacks[i], options[i][0], theta, ad);
    for (int j = 0; j < n; ++j) {
      out[i].push_back(binned(tables[j], false));
      out[i][j].transmit_factor = transmit_factor(stacks[i]);
    }
  }
  return out;
}

// The discretisation error of the models' errors predicted against the adding-doubling
// reference P at N points, from the reference at N/2, Q (derivation in subsurface_auto.h):
// with dP = P - Q taken as a bound on P's own error in every norm, each metric
// e = ||X - P|| / ||P|| (X the model's powers, or for the table X - P = the linear interpolation
// bias B(P)) moves by at most (||dX|| + e ||dP||) / (||P|| - ||dP||), with ||dX|| = ||dP|| for
// lambert and first order (X does not depend on the reference) and ||B(dP)|| for the table.
ModeErrors reference_discretisation(const ReferenceGrid& P, const ReferenceGrid& Q, const ViewErrors& errors, int stride) {
  ReferenceGrid dP = P;
  for (std::size_t i = 0; i < P.size(); ++i)
    for (std::size_t j = 0; j < P[i].size(); ++j) {
      Binned& d = dP[i][j];
      for (std::size_t b = 0; b < d.power.size(); ++b) d.power[b] = P[i][j].power[b] - Q[i][j].power[b];
      d.R_specular = d.T_ballistic = Spectrum(0.0);  // exact (zeroth order) in both
    }
  // ||dP|| / ||P|| in the lambert slot, ||B(dP)|| / ||P|| in the table's: the same sums over
  // views as the errors themselves (shape: sums over views; uniform: the worst view).
  Accumulator acc;
  for (std::size_t i = 0; i < P.size(); ++i) {
    const int n = static_cast<int>(P[i].size());
    for (int j = 0; j < n; ++j) {
      const Relative r = relative_to(combine({{&dP[i][j], 1.0}}), P[i][j]);
      acc.shape_ref += r.shape_ref2;
      record(r, 0, &acc);
      if (n >= 3) record(relative_to(interpolation_bias(dP[i], j, stride), P[i][j]), 2, &acc);
    }
  }
  const ViewErrors rel = finish(acc);
  auto moved = [](double dX, double e, double dP) {
    return dP < 1.0 ? (dX + e * dP) / (1.0 - dP) : std::numeric_limits<double>::infinity();
  };
  ModeErrors out;
  for (int m = 0; m < 3; ++m) {
    const int slot = m == 2 ? 2 : 0;
    const double shape = moved(rel.shape.*kModels[slot], errors.shape.*kModels[m], rel.shape.lambert);
    const double uniform = moved(rel.uniform.*kModels[slot], errors.uniform.*kModels[m], rel.uniform.lambert);
    out.*kModels[m] = std::max(shape, uniform);
  }
  return out;
}

}  // namespace

AutoChoice choose_subsurface_mode(const LayeredMaterial& material, const AutoSettings& settings) {
  const auto t0 = std::chrono::steady_clock::now();
  const Spectrum& albedo = material.lambert_albedo();
  const Binned lambert = lambert_binned(albedo, settings);
  // The prediction's incidences: every other node of the table when that still leaves >= 5
  // (from 89.9 degrees to normal), else every node: half the walks, and the table's
  // interpolation error still follows from second differences (below).
  const int table_nodes = std::max(settings.table.nodes, 1);
  const int stride = table_nodes >= 9 && (table_nodes - 1) % 2 == 0 ? 2 : 1;
  const int n = (table_nodes - 1) / stride + 1;
  // The stack from above, and from below if it transmits (a leaf lit from behind); at each
  // incidence: walk (pooled over rounds) and first order (exact).
  std::vector<std::reference_wrapper<const LayerStack>> stacks{material.base_stack()};
  if (material.transmits()) stacks.push_back(material.flipped_stack());
  std::vector<std::vector<BrdfOptions>> options(stacks.size(), std::vector<BrdfOptions>(n));
  ReferenceGrid first(stacks.size(), std::vector<Binned>(n)), reference = first;
  for (std::size_t i = 0; i < stacks.size(); ++i)
    for (int j = 0; j < n; ++j) {
      options[i][j] = options_at(table_node_cosine(settings.table, j * stride), settings, settings.seed + 104729u * i + 7919u * j);
      first[i][j] = first_order_binned(stacks[i], options[i][j]);
    }
  double spread[3] = {0.0, 0.0, 0.0};
  auto decided = [&](const ViewErrors& e, const double* margin) {
    for (int m = 0; m < 3; ++m)
      if (!(std::abs(std::max(e.shape.*kModels[m], e.uniform.*kModels[m]) - settings.tolerance) >= 2.0 * margin[m])) return false;
    return true;
  };
  ViewErrors worst;
  std::uint64_t walks = 0;
  // With adding-doubling tables (the default) the reference is the adding-doubling solution on
  // the prediction's bins, for every incidence in one solution: exact up to its discretisation
  // error, so no walks, no noise, one pass. A stack it cannot resolve (the table mode's own rule,
  // adding_doubling_resolves, which also sets the full order) keeps the walks.
  bool exact = settings.table.method == TableSettings::Method::AddingDoubling && !settings.test_hooks.walk_reference;
  std::vector<AddingDoublingSettings> ad(stacks.size());
  for (std::size_t i = 0; i < stacks.size() && exact; ++i)
    exact = adding_doubling_resolves(stacks[i], settings.table.quadrature_points, &ad[i]);
  int full_points = 0, reference_points = 0;
  ModeErrors discretisation;
  if (exact) {
    // Stages (subsurface_auto.h): from first_reference_points, doubling, with the estimate of
    // each stage's discretisation error from the one at half its order, until the choice is
    // decided (every model's predicted error at least 2 estimates from the tolerance, as for the
    // walk's noise below) or the full order is reached (then no estimate: the reference as the
    // table mode resolves it).
    for (const AddingDoublingSettings& a : ad) full_points = std::max(full_points, a.quadrature_points);
    int points = settings.first_reference_points > 0 ? std::min(settings.first_reference_points, full_points) : full_points;
    ReferenceGrid half;
    for (;;) {
      reference = adding_doubling_reference(stacks, ad, points, options);
      worst = errors_against(reference, first, lambert, stride, settings, spread);
      reference_points = points;
      discretisation = ModeErrors();
      if (points >= full_points) break;
      if (half.empty()) half = adding_doubling_reference(stacks, ad, std::max(2, points / 2), options);
      discretisation = reference_discretisation(reference, half, worst, stride);
      const double margin[3] = {discretisation.lambert, discretisation.first_order, discretisation.table};
      if (settings.test_hooks.single_reference_stage || decided(worst, margin)) break;
      half = std::move(reference);
      points = std::min(2 * points, full_points);
    }
  }
  // Rounds of walks (doubling, a fixed sequence of seeds: deterministic) until the choice is
  // decided -- every cheaper model's predicted error is at least 2 of its standard deviations
  // away from the tolerance (finish()) -- or the budget is spent. Cheap stacks (thin, absorbing: few events per walk)
  // so get the many walks their rare scattering needs, expensive ones stop once the walk is
  // clearly needed.
  for (int round = 0; !exact && walks < settings.max_walks; ++round) {
    const std::uint64_t more = walks == 0 ? settings.walks : std::min(walks, settings.max_walks - walks);
    for (std::size_t i = 0; i < stacks.size(); ++i)
      for (int j = 0; j < n; ++j) add_walks(stacks[i], options[i][j], more, round, &reference[i][j]);
    walks += more;
    worst = errors_against(reference, first, lambert, stride, settings, spread);
    if (decided(worst, spread)) break;
  }

  AutoChoice ch;
  ch.error_lambert = std::max(worst.shape.lambert, worst.uniform.lambert);
  ch.error_first_order = std::max(worst.shape.first_order, worst.uniform.first_order);
  ch.error_table = std::max(worst.shape.table, worst.uniform.table);
  ch.noise_floor = std::max(worst.shape.noise, worst.uniform.noise);

  const double tol = settings.tolerance;
  // A rough top: the first-order mode refracts through a smooth mirror, which the prediction
  // (delta parts D, a glossy lobe's total among them) cannot tell from the glossy lobe: never
  // chosen. The table mode renders the lobe exactly and the lambert mode's error includes it.
  // Energy-conserving rough inner interfaces too: the first-order mode's interfaces are mirrors;
  // and it does not model diffuse interfaces at all.
  const bool rough = material.base_stack().rough_top() || material.base_stack().energy_conserving_rough() ||
                     material.base_stack().any_diffuse_interface();
  if (ch.error_lambert <= tol) ch.mode = SubsurfaceMode::Lambert;
  else if (!rough && ch.error_first_order <= tol) ch.mode = SubsurfaceMode::FirstOrder;
  else if (ch.error_table <= tol) ch.mode = SubsurfaceMode::Table;
  else ch.mode = SubsurfaceMode::RandomWalk;
  const double chosen = ch.mode == SubsurfaceMode::Lambert      ? ch.error_lambert
                        : ch.mode == SubsurfaceMode::FirstOrder ? ch.error_first_order
                        : ch.mode == SubsurfaceMode::Table      ? ch.error_table
                                                                : 0.0;
  char buf[320];
  std::snprintf(buf, sizeof buf,
                "chose %s (predicted error %.3g %s %.3g; worst over views from 0 to 89.9 deg: lambert %.3g, first-order %.3g, "
                "table %.3g; prediction noise %.2g)",
                short_name(ch.mode), chosen, ch.mode == SubsurfaceMode::RandomWalk ? "reference," : "<=", tol,
                ch.error_lambert, ch.error_first_order, ch.error_table, ch.noise_floor);
  ch.reason = buf;
  if (rough) ch.reason += material.base_stack().any_diffuse_interface() ? " [diffuse interface: first-order excluded]"
                                                                       : " [rough top: first-order excluded]";
  if (exact) {
    ch.reason += string_printf(" [reference: adding-doubling, %d points", reference_points);
    if (reference_points < full_points)
      ch.reason += string_printf(" of %d, discretisation error <= %.2g", full_points,
                                 std::max({discretisation.lambert, discretisation.first_order, discretisation.table}));
    ch.reason += "]";
  }
  ch.reference_points = exact ? reference_points : 0;
  ch.discretisation_lambert = discretisation.lambert;
  ch.discretisation_first_order = discretisation.first_order;
  ch.discretisation_table = discretisation.table;
  ch.walks = walks;
  ch.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return ch;
}

ViewErrors predict_view_errors(const LayeredMaterial& material, double mu, bool from_below, const AutoSettings& settings,
                               std::uint64_t walks) {
  const LayerStack& stack = from_below && material.transmits() ? material.flipped_stack() : material.base_stack();
  const std::uint64_t seed = settings.seed + (from_below ? 104729u : 0u);
  // The walk at mu and at the table nodes around it (one set of walks per distinct cosine).
  const TableNodes at = table_nodes_at(settings.table, mu);
  std::vector<double> cosines = {mu};
  std::vector<Binned> walk(3);
  const double node_mu[2] = {table_node_cosine(settings.table, at.node[0]), table_node_cosine(settings.table, at.node[1])};
  int index[2];
  for (int i = 0; i < 2; ++i) {
    auto it = std::find(cosines.begin(), cosines.end(), node_mu[i]);
    index[i] = static_cast<int>(it - cosines.begin());
    if (it == cosines.end()) cosines.push_back(node_mu[i]);
  }
  for (std::size_t k = 0; k < cosines.size(); ++k)
    add_walks(stack, options_at(cosines[k], settings, seed + 7919u * k), walks, 0, &walk[k]);
  const Binned& here = walk[0];
  const Binned first = first_order_binned(stack, options_at(mu, settings, seed));
  const Binned lambert = lambert_binned(material.lambert_albedo(), settings);

  Accumulator acc;
  const Relative rl = relative_to(combine({{&lambert, 1.0}, {&here, -1.0}}), here);
  acc.shape_ref = rl.shape_ref2;
  record(rl, 0, &acc);
  record(relative_to(combine({{&first, 1.0}, {&here, -1.0}}), here), 1, &acc);
  const std::vector<std::pair<const Binned*, double>> interp = {{&walk[index[0]], at.weight[0]}, {&walk[index[1]], at.weight[1]}};
  std::vector<std::pair<const Binned*, double>> bias = interp;
  bias.push_back({&here, -1.0});
  record_table(combine(bias), here, interp, settings, 0.0, &acc);
  const ViewErrors e = finish(acc);
  return e;
}

namespace {

// The cache key of a material's prediction: its stack, every setting, and the Lambert albedo's
// walk count (the lambert model is that albedo).
std::string auto_key(const LayeredMaterial& m, const AutoSettings& s) {
  std::ostringstream what;
  what << std::hexfloat << "auto prediction\ntolerance " << s.tolerance << " bins " << s.bins_theta << ' ' << s.bins_phi
       << " walks " << s.walks << ' ' << s.max_walks << " seed " << s.seed << " reference stages " << s.first_reference_points << ' '
       << s.test_hooks.single_reference_stage << "\ntable " << s.table.nodes << ' '
       << s.table.grazing_cosine << ' ' << s.table.bins_theta << ' ' << s.table.bins_phi << ' ' << s.table.walks_per_node
       << ' ' << s.table.seed << " method " << static_cast<int>(s.table.method) << ' ' << s.table.quadrature_points
       << "\nalbedo walks " << m.albedo_walks() << '\n'
       << stack_fingerprint(m.base_stack());
  return walk_cache_key(what.str());
}

std::optional<AutoChoice> load_choice(const WalkCache& cache, const std::string& key) {
  const std::optional<std::string> text = cache.load_record("auto", key);
  if (!text) return std::nullopt;
  try {
    const nlohmann::json j = nlohmann::json::parse(*text);
    AutoChoice c;
    if (!parse_subsurface_mode(j.at("mode").get<std::string>(), &c.mode)) throw std::runtime_error("mode");
    c.error_lambert = j.at("error_lambert").get<double>();
    c.error_first_order = j.at("error_first_order").get<double>();
    c.error_table = j.at("error_table").get<double>();
    c.noise_floor = j.at("noise_floor").get<double>();
    c.walks = j.at("walks").get<std::uint64_t>();
    c.seconds = j.at("seconds").get<double>();
    c.reason = j.at("reason").get<std::string>();
    c.reference_points = j.value("reference_points", 0);
    c.discretisation_lambert = j.value("discretisation_lambert", 0.0);
    c.discretisation_first_order = j.value("discretisation_first_order", 0.0);
    c.discretisation_table = j.value("discretisation_table", 0.0);
    c.cached = true;
    return c;
  } catch (const std::exception&) {
    std::fprintf(stderr, "lamina: warning: %s/auto/%s.json: not a valid prediction record; predicting again\n",
                 cache.directory().c_str(), key.c_str());
    return std::nullopt;
  }
}

void store_choice(const WalkCache& cache, const std::string& key, const AutoChoice& c) {
  const nlohmann::json j = {{"mode", subsurface_mode_name(c.mode)}, {"error_lambert", c.error_lambert},
                            {"error_first_order", c.error_first_order}, {"error_table", c.error_table},
                            {"noise_floor", c.noise_floor}, {"walks", c.walks}, {"seconds", c.seconds},
                            {"reason", c.reason}, {"reference_points", c.reference_points},
                            {"discretisation_lambert", c.discretisation_lambert},
                            {"discretisation_first_order", c.discretisation_first_order},
                            {"discretisation_table", c.discretisation_table}};
  cache.store_record("auto", key, j.dump(2) + "\n");
}

}  // namespace

std::vector<AutoChoice> choose_subsurface_modes(const LayeredBindings& bindings, const AutoSettings& settings,
                                                const std::vector<bool>* visible, const WalkCache* cache) {
  std::vector<AutoChoice> out(bindings.by_material.size());
  for (std::size_t i = 0; i < bindings.by_material.size(); ++i) {
    if (!bindings.by_material[i]) continue;
    if (visible && (i >= visible->size() || !(*visible)[i])) {
      out[i].mode = SubsurfaceMode::Lambert;
      out[i].reason = "not visible to camera rays: lambert, no prediction";
      out[i].visible = false;
      continue;
    }
    const LayeredMaterial& m = *bindings.by_material[i];
    const std::string key = cache ? auto_key(m, settings) : "";
    if (cache) {
      if (std::optional<AutoChoice> c = load_choice(*cache, key)) {
        out[i] = *c;
        continue;
      }
    }
    out[i] = choose_subsurface_mode(m, settings);
    if (cache) store_choice(*cache, key, out[i]);
  }
  return out;
}

}  // namespace lamina
