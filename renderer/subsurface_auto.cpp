// The model choice of `--subsurface auto` (derivation of the metric in subsurface_auto.h).
#include "renderer/subsurface_auto.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>

#include "materials/brdf_table.h"
#include "materials/sampling.h"
#include "renderer/layered_table.h"

namespace lamina {
namespace {

// Sums of squares over bins, incidences, channels (and sides of the stack).
struct ErrorSums {
  double ref2 = 0.0;     // sum P_walk^2 (noisy)
  double noise2 = 0.0;   // sum sigma_b^2 of the walk's bins
  double lambert2 = 0.0, first2 = 0.0;  // sum (P_m - P_walk)^2 (noisy)
  double delta_ref2 = 0.0;      // sum (D + R_diffuse + T_diffuse)^2, D = R_specular + T_ballistic
  double delta_lambert2 = 0.0;  // the same, missing in lambert (first order has them exactly)
};

// The coarse tables of one stack at the prediction's incidences: the walk's (running pooled
// estimate over rounds of walks) and first order's (exact, computed once).
struct Incidence {
  BrdfOptions options;
  BrdfTable first;
  std::vector<Spectrum> walk_value, walk_var;  // pooled bin mean and its variance (stderr^2)
  Spectrum delta;                              // R_specular + T_ballistic (exact)
  std::uint64_t walks = 0;
};

std::vector<Incidence> make_incidences(const LayerStack& stack, const AutoSettings& s, std::uint64_t seed) {
  std::vector<Incidence> out(s.incidences);
  for (int j = 0; j < s.incidences; ++j) {
    BrdfOptions& o = out[j].options;
    const double mu = (j + 0.5) / s.incidences;
    o.theta_i_deg = std::acos(mu) * 180.0 / kPi;
    o.bins_theta = s.bins_theta;
    o.bins_phi = s.bins_phi;
    o.seed = seed + 7919u * static_cast<std::uint64_t>(j);
    out[j].first = brdf_table_first_order(stack, o);
    out[j].delta = out[j].first.totals.R_specular.value + out[j].first.totals.T_ballistic.value;
  }
  return out;
}

// `walks` more walks at each incidence (a new seed per round), pooled with the earlier ones:
// mean = (N1 m1 + N2 m2) / (N1 + N2), var = (N1^2 v1 + N2^2 v2) / (N1 + N2)^2.
void add_walks(const LayerStack& stack, std::uint64_t walks, int round, std::vector<Incidence>* incidences) {
  for (Incidence& in : *incidences) {
    BrdfOptions o = in.options;
    o.samples = walks;
    o.seed = in.options.seed + 1000003u * static_cast<std::uint64_t>(round);
    const BrdfTable t = brdf_table_monte_carlo(stack, o);
    const double n1 = static_cast<double>(in.walks), n2 = static_cast<double>(walks), n = n1 + n2;
    in.walk_value.resize(t.value.size());
    in.walk_var.resize(t.value.size());
    for (std::size_t b = 0; b < t.value.size(); ++b) {
      in.walk_value[b] = (n1 * in.walk_value[b] + n2 * t.value[b]) * (1.0 / n);
      in.walk_var[b] = (n1 * n1 * in.walk_var[b] + n2 * n2 * t.stderr_[b] * t.stderr_[b]) * (1.0 / (n * n));
    }
    in.walks += walks;
  }
}

void accumulate(const std::vector<Incidence>& incidences, const Spectrum& lambert_albedo, const AutoSettings& s,
                ErrorSums* e) {
  for (const Incidence& in : incidences) {
    const BrdfTable& first = in.first;
    Spectrum diffuse_total(0.0);  // R_diffuse + T_diffuse of the walk at this incidence
    for (int side = 0; side < 2; ++side)
      for (int k = 0; k < s.bins_theta; ++k) {
        // P(B) = value(B) * Omega_proj(B) (brdf_table.h): the bin's fraction of the power.
        const double omega = first.projected_solid_angle(k);
        for (int m = 0; m < s.bins_phi; ++m) {
          const int b = first.bin_index(static_cast<BrdfSide>(side), k, m);
          for (int c = 0; c < kChannels; ++c) {
            const double pw = in.walk_value[b][c] * omega;
            const double vw = in.walk_var[b][c] * omega * omega;
            const double pf = first.value[b][c] * omega;
            // Lambert: f = albedo / pi on the reflect side only.
            const double pl = side == 0 ? lambert_albedo[c] / kPi * omega : 0.0;
            diffuse_total[c] += pw;
            e->ref2 += pw * pw;
            e->noise2 += vw;
            e->lambert2 += (pl - pw) * (pl - pw);
            e->first2 += (pf - pw) * (pf - pw);
          }
        }
      }
    // The delta parts, exact (zeroth order) in both the walk's totals and first order; lambert
    // has none: it misses the fraction D / (D + diffuse) of the light the surface returns under
    // uniform illumination (a delta lobe never sees a point light: it shows the environment and
    // other surfaces, which is where a pixel misses it).
    for (int c = 0; c < kChannels; ++c) {
      const double total = in.delta[c] + diffuse_total[c];
      e->delta_ref2 += total * total;
      e->delta_lambert2 += in.delta[c] * in.delta[c];
    }
  }
}

// sqrt(max(a - noise, 0) / max(b - noise, tiny)): the noise-corrected relative RMS.
double relative_rms(double diff2, double ref2, double noise2) {
  const double num = std::max(diff2 - noise2, 0.0);
  const double den = std::max(ref2 - noise2, 1e-300);
  return std::sqrt(num / den);
}

}  // namespace

AutoChoice choose_subsurface_mode(const LayeredMaterial& material, const AutoSettings& settings) {
  const auto t0 = std::chrono::steady_clock::now();
  const Spectrum& albedo = material.lambert_albedo();
  // The stack from above, and from below if it transmits (a leaf lit from behind).
  std::vector<LayerStack> stacks{material.base_stack()};
  if (material.transmits()) stacks.push_back(flipped(material.base_stack()));
  std::vector<std::vector<Incidence>> incidences;
  for (std::size_t i = 0; i < stacks.size(); ++i)
    incidences.push_back(make_incidences(stacks[i], settings, settings.seed + 104729u * i));
  // Rounds of walks until the prediction resolves the tolerance (noise floor <= tolerance / 2)
  // or the budget is spent: deterministic (a fixed sequence of seeds), and cheap stacks (thin,
  // absorbing: few events per walk) get the many walks their rare scattering needs.
  ErrorSums e;
  std::uint64_t walks = 0;
  for (int round = 0; walks < settings.max_walks; ++round) {
    const std::uint64_t more = walks == 0 ? settings.walks : walks;  // doubling
    for (std::size_t i = 0; i < stacks.size(); ++i) add_walks(stacks[i], more, round, &incidences[i]);
    walks += more;
    e = ErrorSums{};
    for (const auto& in : incidences) accumulate(in, albedo, settings, &e);
    if (std::sqrt(e.noise2 / std::max(e.ref2 - e.noise2, 1e-300)) <= 0.5 * settings.tolerance) break;
  }

  AutoChoice ch;
  // The diffuse part's shape relative to the diffuse part; the missing delta part relative to
  // all the light returned (energy under uniform illumination); the larger of the two.
  const double delta_lambert = e.delta_ref2 > 0.0 ? std::sqrt(e.delta_lambert2 / e.delta_ref2) : 0.0;
  ch.error_lambert = std::max(relative_rms(e.lambert2, e.ref2, e.noise2), delta_lambert);
  ch.noise_floor = std::sqrt(e.noise2 / std::max(e.ref2 - e.noise2, 1e-300));
  ch.error_first_order = relative_rms(e.first2, e.ref2, e.noise2);
  // The table mode: its own Monte Carlo noise. Per-bin variance scales as 1 / (walks per node)
  // and, for the same total power, the sum of squared bin errors scales with the bin count
  // (sigma_b^2 ~ P_b / N, sum_b P_b fixed): scale the prediction's noise accordingly.
  const TableSettings table;
  const double bins_ratio = static_cast<double>(table.bins_theta * table.bins_phi) / (settings.bins_theta * settings.bins_phi);
  const double walks_ratio = static_cast<double>(walks) / static_cast<double>(table.walks_per_node);
  // Relative to the noise-corrected reference power.
  ch.error_table = std::sqrt(e.noise2 * bins_ratio * walks_ratio / std::max(e.ref2 - e.noise2, 1e-300));

  const double tol = settings.tolerance;
  if (ch.error_lambert <= tol) ch.mode = SubsurfaceMode::Lambert;
  else if (ch.error_first_order <= tol) ch.mode = SubsurfaceMode::FirstOrder;
  else if (ch.error_table <= tol) ch.mode = SubsurfaceMode::Table;
  else ch.mode = SubsurfaceMode::RandomWalk;
  const double chosen = ch.mode == SubsurfaceMode::Lambert      ? ch.error_lambert
                        : ch.mode == SubsurfaceMode::FirstOrder ? ch.error_first_order
                        : ch.mode == SubsurfaceMode::Table      ? ch.error_table
                                                                : 0.0;
  char buf[256];
  std::snprintf(buf, sizeof buf, "chose %s (predicted error %.3g %s %.3g; lambert %.3g, first-order %.3g, table %.3g; prediction noise %.2g)",
                subsurface_mode_name(ch.mode), chosen, ch.mode == SubsurfaceMode::RandomWalk ? "reference," : "<=", tol,
                ch.error_lambert, ch.error_first_order, ch.error_table, ch.noise_floor);
  ch.reason = buf;
  ch.walks = walks;
  ch.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return ch;
}

std::vector<bool> camera_visible_materials(const Scene& scene, const Camera& camera, int width, int height, int grid) {
  const SceneDesc& desc = scene.desc();
  std::vector<bool> seen(desc.materials.size(), false);
  const int nx = std::min(width, grid), ny = std::min(height, grid);
  RayCounters rays;
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) {
      // The centre of cell (i, j) of an nx x ny grid over the film, in pixels.
      const glm::dvec2 film((i + 0.5) * width / nx, (j + 0.5) * height / ny);
      SurfaceHit hit;
      if (!scene.intersect(camera.generate_ray(film), &hit, &rays)) continue;
      const int m = desc.meshes[hit.mesh].material;
      if (m >= 0 && m < static_cast<int>(seen.size())) seen[m] = true;
    }
  return seen;
}

std::vector<AutoChoice> choose_subsurface_modes(const LayeredBindings& bindings, const AutoSettings& settings,
                                                const std::vector<bool>* visible) {
  std::vector<AutoChoice> out(bindings.by_material.size());
  for (std::size_t i = 0; i < bindings.by_material.size(); ++i) {
    if (!bindings.by_material[i]) continue;
    if (visible && (i >= visible->size() || !(*visible)[i])) {
      out[i].mode = SubsurfaceMode::Lambert;
      out[i].reason = "not visible to camera rays: lambert, no prediction";
      continue;
    }
    out[i] = choose_subsurface_mode(*bindings.by_material[i], settings);
  }
  return out;
}

}  // namespace lamina
