#include "materials/fit/albedo_lookup.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <limits>

#include <nlopt.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "materials/tables/albedo.h"

namespace lamina {

Spectrum linear_rgb_to_lab(const Spectrum& c) {
  // Rec. 709 / sRGB primaries, D65 (IEC 61966-2-1 sec. 5.2).
  const double X = 0.4124 * c[0] + 0.3576 * c[1] + 0.1805 * c[2];
  const double Y = 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2];
  const double Z = 0.0193 * c[0] + 0.1192 * c[1] + 0.9505 * c[2];
  const double Xn = 0.4124 + 0.3576 + 0.1805, Yn = 1.0, Zn = 0.0193 + 0.1192 + 0.9505;  // RGB (1, 1, 1)
  // CIE 15:2004 eq. 8.3-8.5: f(t) = t^(1/3) above (6/29)^3, else linear.
  auto f = [](double t) {
    constexpr double d = 6.0 / 29.0;
    return t > d * d * d ? std::cbrt(t) : t / (3.0 * d * d) + 4.0 / 29.0;
  };
  const double fx = f(X / Xn), fy = f(Y / Yn), fz = f(Z / Zn);
  return {116.0 * fy - 16.0, 500.0 * (fx - fy), 200.0 * (fy - fz)};
}

double delta_e76(const Spectrum& a, const Spectrum& b) {
  const Spectrum d = a - b;
  return std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
}

Spectrum AlbedoLookup::at(double u0, double u1) const {
  const double x = std::clamp(u0, 0.0, 1.0) * (nodes - 1), y = std::clamp(u1, 0.0, 1.0) * (nodes - 1);
  const int i = std::min(static_cast<int>(x), nodes - 2), j = std::min(static_cast<int>(y), nodes - 2);
  const double fx = x - i, fy = y - j;
  auto node = [&](int a, int b) { return albedo[static_cast<std::size_t>(a) * nodes + b]; };
  return (1 - fx) * ((1 - fy) * node(i, j) + fy * node(i, j + 1)) + fx * ((1 - fy) * node(i + 1, j) + fy * node(i + 1, j + 1));
}

std::vector<StackParameter> parse_albedo_axes(const StackTemplate& t, const std::vector<FitParameterSpec>& axes,
                                              const AxisAdmission& admit) {
  if (axes.size() != 2) throw FitError("an albedo lookup needs two parameters, got " + std::to_string(axes.size()));
  auto text = [](double v) {
    char b[32];
    std::snprintf(b, sizeof b, "%g", v);
    return std::string(b);
  };
  std::vector<StackParameter> ps;
  for (const FitParameterSpec& a : axes) {
    StackParameter p;
    try {
      p = parse_stack_parameter(t, a.path);
    } catch (const StackParameterError& e) {
      throw FitError(e.what());
    }
    const auto [lo, hi] = admit(a, p);
    if (!std::isfinite(a.lower) || !std::isfinite(a.upper) || !(a.lower < a.upper) || a.lower < lo || a.upper > hi)
      throw FitError(a.path + ": bounds must be finite, increasing and inside [" + text(lo) + ", " + text(hi) + "] (got " +
                     text(a.lower) + ":" + text(a.upper) + ")");
    ps.push_back(p);
  }
  try {
    check_parameter_set(ps);
  } catch (const StackParameterError& e) {
    throw FitError(e.what());
  }
  return ps;
}

std::vector<StackParameter> check_albedo_axes(const StackTemplate& t, const std::vector<FitParameterSpec>& axes) {
  return parse_albedo_axes(t, axes, [&](const FitParameterSpec& a, const StackParameter& p) {
    if (p.spectral()) throw FitError(a.path + ": an albedo lookup's axis must be a scalar parameter (a fraction, a thickness)");
    const std::string fixed = rough_projection_refusal(t, p);
    if (!fixed.empty()) throw FitError(fixed);
    return std::pair<double, double>(p.min_value(), p.max_value());
  });
}

AlbedoLookup build_albedo_lookup(const StackTemplate& t, const std::vector<FitParameterSpec>& axes, int nodes,
                                 const AddingDoublingSettings& settings, AlbedoKind kind) {
  if (nodes < 2 || nodes > 1024) throw FitError("an albedo lookup needs 2 to 1024 nodes per axis, got " + std::to_string(nodes));
  const std::vector<StackParameter> ps = check_albedo_axes(t, axes);
  AlbedoLookup table;
  table.axes = axes;
  table.kind = kind;
  table.nodes = nodes;
  table.albedo.resize(static_cast<std::size_t>(nodes) * nodes);
  table.lab.resize(table.albedo.size());
  auto solve = [&](int i, int j, LayerStack* stack) {
    const Spectrum v[2] = {Spectrum(axes[0].lower + (axes[0].upper - axes[0].lower) * i / (nodes - 1.0)),
                           Spectrum(axes[1].lower + (axes[1].upper - axes[1].lower) * j / (nodes - 1.0))};
    apply_parameters(t, ps, v, stack);
    // Diffuse incidence: every solution carries it (the collimated angle is irrelevant).
    const std::size_t k = static_cast<std::size_t>(i) * nodes + j;
    table.albedo[k] = kind == AlbedoKind::kTotal ? adding_doubling_totals(*stack, 1.0, settings).R_hemispherical
                                                 : diffuse_bihemispherical_albedo_adding_doubling(*stack, settings);
    table.lab[k] = linear_rgb_to_lab(table.albedo[k]);
  };
  // The first node alone: under rough interfaces it makes their projection (the axes change
  // neither alpha nor an index: check_albedo_axes), which interface_fourier.h's cache then gives
  // every other node, instead of each thread making it at once.
  LayerStack first;
  solve(0, 0, &first);
  tbb::parallel_for(0, nodes, [&](int i) {
    LayerStack stack;  // one scratch stack per row
    for (int j = i == 0 ? 1 : 0; j < nodes; ++j) solve(i, j, &stack);
  });
  return table;
}

AlbedoMatch match_albedo(const AlbedoLookup& t, const Spectrum& linear_rgb) {
  const Spectrum target = linear_rgb_to_lab(linear_rgb);
  const int n = t.nodes;
  std::size_t best = 0;
  double best_e = std::numeric_limits<double>::infinity();
  for (std::size_t k = 0; k < t.lab.size(); ++k) {
    const double e = delta_e76(t.lab[k], target);
    if (e < best_e) best_e = e, best = k;
  }
  // Refine on the bilinear surface: minimise Delta E^2 over (u0, u1) in [0, 1]^2 by BOBYQA (as
  // lamina fit does) from the nearest node, first step one cell, to 1e-4 of a cell.
  struct Target {
    const AlbedoLookup* t;
    Spectrum lab;
  } target_data{&t, target};
  auto objective = [](unsigned, const double* x, double*, void* data) -> double {
    const Target* d = static_cast<const Target*>(data);
    const double e = delta_e76(linear_rgb_to_lab(d->t->at(x[0], x[1])), d->lab);
    return e * e;
  };
  const double cell = 1.0 / (n - 1);
  double x[2] = {static_cast<double>(best / n) * cell, static_cast<double>(best % n) * cell};
  const double lo[2] = {0.0, 0.0}, hi[2] = {1.0, 1.0}, step[2] = {cell, cell};
  nlopt_opt opt = nlopt_create(NLOPT_LN_BOBYQA, 2);
  nlopt_set_lower_bounds(opt, lo);
  nlopt_set_upper_bounds(opt, hi);
  nlopt_set_initial_step(opt, step);
  nlopt_set_min_objective(opt, objective, &target_data);
  nlopt_set_xtol_abs1(opt, 1e-4 * cell);
  nlopt_set_maxeval(opt, 500);
  double f = best_e * best_e;
  if (nlopt_optimize(opt, x, &f) < 0) f = best_e * best_e, x[0] = static_cast<double>(best / n) * cell, x[1] = static_cast<double>(best % n) * cell;
  nlopt_destroy(opt);
  const double u0 = x[0], u1 = x[1];
  best_e = std::sqrt(f);
  AlbedoMatch m;
  m.value[0] = t.axes[0].lower + u0 * (t.axes[0].upper - t.axes[0].lower);
  m.value[1] = t.axes[1].lower + u1 * (t.axes[1].upper - t.axes[1].lower);
  m.albedo = t.at(u0, u1);
  m.delta_e = best_e;
  return m;
}

AlbedoMapMatch match_albedo_map_by(const std::function<AlbedoMatch(const Spectrum&)>& match, const float* rgb,
                                   std::size_t texels, const std::function<void(std::size_t)>& on_progress) {
  AlbedoMapMatch out;
  out.value[0].resize(texels);
  out.value[1].resize(texels);
  out.albedo.resize(texels);
  out.delta_e.resize(texels);
  // Blocks of a fixed size only pace the progress reports: every texel is matched on its own.
  constexpr std::size_t kBlock = 4096;
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, texels, kBlock), [&](const tbb::blocked_range<std::size_t>& r) {
    for (std::size_t i = r.begin(); i < r.end(); ++i) {
      const float* p = rgb + 3 * i;
      const AlbedoMatch m = match(Spectrum(p[0], p[1], p[2]));
      out.value[0][i] = m.value[0];
      out.value[1][i] = m.value[1];
      out.albedo[i] = m.albedo;
      out.delta_e[i] = m.delta_e;
    }
    if (on_progress) on_progress(r.size());
  });
  return out;
}

AlbedoMapMatch match_albedo_map(const AlbedoLookup& table, const float* rgb, std::size_t texels,
                                const std::function<void(std::size_t)>& on_progress) {
  return match_albedo_map_by([&](const Spectrum& c) { return match_albedo(table, c); }, rgb, texels, on_progress);
}

DeltaEStatistics delta_e_statistics(std::vector<double> e, double threshold) {
  DeltaEStatistics s;
  if (e.empty()) return s;
  for (double v : e) {
    s.mean += v;
    if (v > threshold) ++s.above;
  }
  s.mean /= static_cast<double>(e.size());
  std::sort(e.begin(), e.end());
  const std::size_t n = e.size();
  s.median = n % 2 ? e[n / 2] : 0.5 * (e[n / 2 - 1] + e[n / 2]);
  // Nearest rank: the ceil(0.95 n)-th smallest value (in integers: 0.95 n is not exact in binary).
  const std::size_t rank = (95 * n + 99) / 100;
  s.p95 = e[rank - 1];
  s.max = e.back();
  return s;
}

}  // namespace lamina
