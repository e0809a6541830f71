#include "materials/fit/spectral_albedo.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <limits>
#include <string>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "materials/spectral/chromophores.h"
#include "materials/stack/stack_file.h"
#include "materials/tables/albedo.h"

namespace lamina {

ChromophoreMaterial load_chromophore_material(const std::string& path) {
  return {load_stack_template(path), load_spectral_stack(path)};
}

bool chromophore_axes(const std::vector<FitParameterSpec>& axes) {
  if (axes.empty()) return false;
  for (const FitParameterSpec& a : axes)
    if (a.path.find(".chromophores.") == std::string::npos) return false;
  return true;
}

std::vector<StackParameter> check_spectral_albedo_axes(const ChromophoreMaterial& m, const std::vector<FitParameterSpec>& axes) {
  return parse_albedo_axes(m.stack, axes, [](const FitParameterSpec& a, const StackParameter& p) {
    if (p.kind != StackParameter::Kind::kChromophore)
      throw FitError(a.path + ": the spectral albedo fit's axes are chromophore parameters (layers[i].chromophores.KEY)");
    return std::pair<double, double>(0.0, p.chromophore_max);
  });
}

Spectrum spectral_albedo_colour(const ChromophoreMaterial& m, const std::vector<StackParameter>& ps, const double* values,
                                AlbedoKind kind, const AddingDoublingSettings& settings) {
  const Spectrum bound[2] = {Spectrum(values[0]), Spectrum(values[1])};
  SpectralStack s = m.spectral;
  for (std::size_t l = 0; l < s.chromophores.size(); ++l)
    if (s.chromophores[l]) s.chromophores[l] = bound_chromophores(m.stack, ps, bound, static_cast<int>(l));
  AddingDoublingSettings one = settings;
  one.only_channel = 0;  // each wavelength is a grey stack
  // The colour grid's 85 wavelengths; the solutions are independent, the sum is in order.
  return rec709_channel_mean([&](double nm) {
    const LayerStack grey = stack_at_wavelength(s, nm);
    return kind == AlbedoKind::kTotal ? adding_doubling_totals(grey, 1.0, one).R_hemispherical[0]
                                      : diffuse_bihemispherical_albedo_adding_doubling(grey, one)[0];
  });
}

namespace {

// Catmull-Rom weights of the four nodes around t in [0, 1] (between nodes 1 and 2): the cubic
// through the nodes with slopes (p2 - p0) / 2 and (p3 - p1) / 2 at nodes 1 and 2 (Catmull and
// Rom 1974; Keys 1981 with a = -1/2), C1 across nodes, exact for quadratics.
std::array<double, 4> catmull_rom(double t) {
  const double t2 = t * t, t3 = t2 * t;
  return {0.5 * (-t3 + 2 * t2 - t), 0.5 * (3 * t3 - 5 * t2 + 2), 0.5 * (-3 * t3 + 4 * t2 + t), 0.5 * (t3 - t2)};
}

}  // namespace

Spectrum SpectralAlbedoTable::at(double u0, double u1) const {
  const double x = std::clamp(u0, 0.0, 1.0) * (nodes - 1), y = std::clamp(u1, 0.0, 1.0) * (nodes - 1);
  const int i = std::min(static_cast<int>(x), nodes - 2), j = std::min(static_cast<int>(y), nodes - 2);
  const std::array<double, 4> wx = catmull_rom(x - i), wy = catmull_rom(y - j);
  // Beyond the grid's edge, the node linearly extrapolated from the two inside (p_-1 = 2 p_0 - p_1),
  // which keeps the edge cells' interpolant a cubic through the inner nodes.
  auto node = [&](int a, int b) -> Spectrum {
    auto inside = [&](int p, int q) { return colour[static_cast<std::size_t>(p) * nodes + q]; };
    auto column = [&](int p, int q) {
      if (q < 0) return 2.0 * inside(p, 0) - inside(p, 1);
      if (q >= nodes) return 2.0 * inside(p, nodes - 1) - inside(p, nodes - 2);
      return inside(p, q);
    };
    if (a < 0) return 2.0 * column(0, b) - column(1, b);
    if (a >= nodes) return 2.0 * column(nodes - 1, b) - column(nodes - 2, b);
    return column(a, b);
  };
  Spectrum out(0.0);
  for (int p = 0; p < 4; ++p) {
    Spectrum row(0.0);
    for (int q = 0; q < 4; ++q) row += wy[q] * node(i - 1 + p, j - 1 + q);
    out += wx[p] * row;
  }
  return out;
}

SpectralAlbedoTable build_spectral_albedo_table(const ChromophoreMaterial& m, const std::vector<FitParameterSpec>& axes,
                                                int nodes, const AddingDoublingSettings& settings, AlbedoKind kind) {
  if (nodes < 4 || nodes > 257) throw FitError("a spectral albedo table needs 4 to 257 nodes per axis, got " + std::to_string(nodes));
  const std::vector<StackParameter> ps = check_spectral_albedo_axes(m, axes);
  SpectralAlbedoTable table;
  table.axes = axes;
  table.kind = kind;
  table.nodes = nodes;
  table.colour.resize(static_cast<std::size_t>(nodes) * nodes);
  table.lab.resize(table.colour.size());
  tbb::parallel_for(std::size_t{0}, table.colour.size(), [&](std::size_t k) {
    const int i = static_cast<int>(k / nodes), j = static_cast<int>(k % nodes);
    const double v[2] = {axes[0].lower + (axes[0].upper - axes[0].lower) * i / (nodes - 1.0),
                         axes[1].lower + (axes[1].upper - axes[1].lower) * j / (nodes - 1.0)};
    table.colour[k] = spectral_albedo_colour(m, ps, v, kind, settings);
    table.lab[k] = linear_rgb_to_lab(table.colour[k]);
  });
  return table;
}

namespace {

// r(u) = Lab(table(u)) - target, and its Jacobian by central differences of 1e-6 (one-sided at
// the box's faces): the interpolant is a cubic per cell, so the truncation error is ~1e-12 of
// its third derivative, far below what a match needs.
struct Residual {
  const SpectralAlbedoTable* t;
  Spectrum target;
  Spectrum at(const double u[2]) const { return linear_rgb_to_lab(t->at(u[0], u[1])) - target; }
  void jacobian(const double u[2], Spectrum J[2]) const {
    constexpr double h = 1e-6;
    for (int k = 0; k < 2; ++k) {
      double lo[2] = {u[0], u[1]}, hi[2] = {u[0], u[1]};
      lo[k] = std::max(0.0, u[k] - h);
      hi[k] = std::min(1.0, u[k] + h);
      J[k] = (1.0 / (hi[k] - lo[k])) * (at(hi) - at(lo));
    }
  }
};

double squared(const Spectrum& r) { return r[0] * r[0] + r[1] * r[1] + r[2] * r[2]; }

}  // namespace

AlbedoMatch match_spectral_albedo(const SpectralAlbedoTable& t, const Spectrum& linear_rgb) {
  const Residual res{&t, linear_rgb_to_lab(linear_rgb)};
  const int n = t.nodes;
  std::size_t best = 0;
  double best_e = std::numeric_limits<double>::infinity();
  for (std::size_t k = 0; k < t.lab.size(); ++k) {
    const double e = delta_e76(t.lab[k], res.target);
    if (e < best_e) best_e = e, best = k;
  }
  // Levenberg-Marquardt with the box as a projection (Madsen, Nielsen and Tingleff 2004, alg.
  // 3.16; a trial step is clipped to [0, 1]^2, and a coordinate on a face whose gradient points
  // out of the box is held there): the step solves (J^T J + mu diag(J^T J)) d = -J^T r.
  double u[2] = {static_cast<double>(best / n) / (n - 1), static_cast<double>(best % n) / (n - 1)};
  Spectrum r = res.at(u);
  double f = squared(r), mu = 1e-3;
  for (int iteration = 0; iteration < 100; ++iteration) {
    Spectrum J[2];
    res.jacobian(u, J);
    double A[2][2], g[2];
    for (int a = 0; a < 2; ++a) {
      g[a] = J[a][0] * r[0] + J[a][1] * r[1] + J[a][2] * r[2];
      for (int b = 0; b < 2; ++b) A[a][b] = J[a][0] * J[b][0] + J[a][1] * J[b][1] + J[a][2] * J[b][2];
    }
    bool held[2];
    for (int a = 0; a < 2; ++a) held[a] = (u[a] <= 0.0 && g[a] > 0.0) || (u[a] >= 1.0 && g[a] < 0.0);
    if (std::abs(held[0] ? 0.0 : g[0]) + std::abs(held[1] ? 0.0 : g[1]) < 1e-14) break;  // stationary
    double trial[2], d[2] = {0.0, 0.0};
    const double m00 = held[0] ? 1.0 : A[0][0] * (1 + mu) + 1e-300, m11 = held[1] ? 1.0 : A[1][1] * (1 + mu) + 1e-300;
    const double m01 = held[0] || held[1] ? 0.0 : A[0][1];
    const double det = m00 * m11 - m01 * m01;
    if (!held[0]) d[0] = -(m11 * g[0] - m01 * (held[1] ? 0.0 : g[1])) / det;
    if (!held[1]) d[1] = -(m00 * g[1] - m01 * (held[0] ? 0.0 : g[0])) / det;
    for (int a = 0; a < 2; ++a) trial[a] = std::clamp(u[a] + d[a], 0.0, 1.0);
    const double step = std::abs(trial[0] - u[0]) + std::abs(trial[1] - u[1]);
    const Spectrum rt = res.at(trial);
    const double ft = squared(rt);
    if (ft < f) {
      u[0] = trial[0], u[1] = trial[1], r = rt;
      const bool converged = f - ft < 1e-14 * (1.0 + f) && step < 1e-9;
      f = ft;
      mu = std::max(mu / 3.0, 1e-12);
      if (converged) break;
    } else {
      mu *= 4.0;
      if (step < 1e-12 || mu > 1e12) break;
    }
  }
  AlbedoMatch match;
  for (int a = 0; a < 2; ++a)  // a bound exactly, where the match holds it
    match.value[a] = u[a] >= 1.0 ? t.axes[a].upper : t.axes[a].lower + u[a] * (t.axes[a].upper - t.axes[a].lower);
  match.albedo = t.at(u[0], u[1]);
  match.delta_e = std::sqrt(f);
  return match;
}

AlbedoMapMatch match_spectral_albedo_map(const SpectralAlbedoTable& table, const float* rgb, std::size_t texels,
                                         const std::function<void(std::size_t)>& on_progress) {
  return match_albedo_map_by([&](const Spectrum& c) { return match_spectral_albedo(table, c); }, rgb, texels,
                             on_progress);
}

}  // namespace lamina
