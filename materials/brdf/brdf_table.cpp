#include "materials/brdf/brdf_table.h"

#include <algorithm>
#include <cmath>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "materials/analytic/first_order.h"
#include "materials/interfaces/fresnel.h"
#include "materials/interfaces/microfacet.h"
#include "materials/analytic/zeroth_order.h"

namespace lamina {

namespace {

constexpr double kDegree = kPi / 180.0;
constexpr int kEndKinds = 5;  // number of WalkResult::End values

// Runs photons [0, n) in a fixed number of contiguous blocks (independent of the thread count);
// each block accumulates into its own vector of `size` doubles in photon order, and the blocks
// are summed in block order, so the result has the same bits for any number of threads.
template <typename PhotonFn>
std::vector<double> run_photons(std::uint64_t n, std::size_t size, const PhotonFn& photon,
                                const std::function<void(std::uint64_t)>& on_progress = {}) {
  const std::uint64_t blocks = std::max<std::uint64_t>(1, std::min<std::uint64_t>(n, 64));
  std::vector<std::vector<double>> partial(blocks);
  tbb::parallel_for(tbb::blocked_range<std::uint64_t>(0, blocks, 1),
                    [&](const tbb::blocked_range<std::uint64_t>& range) {
                      for (std::uint64_t b = range.begin(); b != range.end(); ++b) {
                        std::vector<double>& acc = partial[b];
                        acc.assign(size, 0.0);
                        const std::uint64_t first = n * b / blocks, last = n * (b + 1) / blocks;
                        constexpr std::uint64_t kReportEvery = 4096;
                        for (std::uint64_t i = first; i < last; ++i) {
                          photon(i, acc);
                          if (on_progress && (i - first + 1) % kReportEvery == 0) on_progress(kReportEvery);
                        }
                        if (on_progress) on_progress((last - first) % kReportEvery);
                      }
                    });
  std::vector<double> total(size, 0.0);
  for (const std::vector<double>& acc : partial)
    for (std::size_t j = 0; j < size; ++j) total[j] += acc[j];
  return total;
}

// Mean and standard error of the mean from the sum and the sum of squares of n samples.
void mean_and_error(double sum, double sum2, std::uint64_t n, double* mean, double* error) {
  const double nn = static_cast<double>(n);
  *mean = sum / nn;
  const double var = n > 1 ? std::max(0.0, (sum2 - sum * sum / nn) / (nn - 1.0)) : 0.0;
  *error = std::sqrt(var / nn);
}

// atan2(y, x) within 3e-8 radians for a fraction of the library's cost: the octant reduction
// t = min(|x|, |y|) / max(|x|, |y|) in [0, 1], Abramowitz and Stegun 4.4.49 for atan(t) (a
// polynomial in t^2 whose error is at most 2e-8 on [0, 1]), and the octant's symmetries.
double approximate_atan2(double y, double x) {
  const double ax = std::abs(x), ay = std::abs(y);
  const double hi = std::max(ax, ay);
  if (!(hi > 0.0)) return std::atan2(y, x);  // the origin (and its signed zeros)
  const double t = std::min(ax, ay) / hi, t2 = t * t;
  double a = t * (1.0 + t2 * (-0.3333314528 + t2 * (0.1999355085 + t2 * (-0.1420889944 + t2 * (0.1065626393 +
             t2 * (-0.0752896400 + t2 * (0.0429096138 + t2 * (-0.0161657367 + t2 * 0.0028662257))))))));
  if (ay > ax) a = 0.5 * kPi - a;
  if (x < 0.0) a = kPi - a;
  return y < 0.0 ? -a : a;
}

// Index of the bin of an outside direction w (and its row k), or -1 (w.z == 0).
int bin_of(const BrdfTable& table, const glm::dvec3& w, double phi_i, int* row) {
  if (w.z == 0.0) return -1;
  const BrdfOptions& o = table.options;
  const BrdfSide side = w.z > 0.0 ? BrdfSide::Reflect : BrdfSide::Transmit;
  const int k = std::min(o.bins_theta - 1, static_cast<int>(std::abs(w.z) * o.bins_theta));
  *row = k;
  return table.bin_index(side, k, azimuth_bin(w.x, w.y, phi_i, o.bins_phi));
}

BrdfTable empty_table(const BrdfOptions& options) {
  BrdfTable table;
  table.options = options;
  const std::size_t nb = 2u * options.bins_theta * options.bins_phi;
  table.value.assign(nb, Spectrum(0.0));
  table.stderr_ = table.single = table.multiple = table.single_stderr = table.value;
  table.ends.assign(kEndKinds, 0);
  return table;
}

// Fractions of incident power: totals slots in the accumulator.
enum TotalSlot { kRs, kRd, kTb, kTd, kAbs, kAbsDirect, kRsWalk, kTbWalk, kUnresolved, kTotalSlots };

}  // namespace

glm::dvec3 incident_direction(double theta_i_deg, double phi_i_deg) {
  const double t = theta_i_deg * kDegree, p = phi_i_deg * kDegree;
  return {std::sin(t) * std::cos(p), std::sin(t) * std::sin(p), std::cos(t)};
}

int azimuth_bin(double x, double y, double phi_i, int bins) {
  // A photon's azimuth is only rarely within the approximation's error of a bin's edge: there
  // the definition decides, with the library's atan2, so that every bin is the definition's.
  // Elsewhere the approximation in turns (multiplications where the definition divides) gives
  // the same bin: the margin, 1e-6 radians, is 30 times its error.
  constexpr double kInv2Pi = 1.0 / (2.0 * kPi);
  double turns = (approximate_atan2(y, x) - phi_i) * kInv2Pi;
  turns -= std::floor(turns);
  const double position = turns * bins;
  const int m = static_cast<int>(position);
  const double to_edge = position - m, margin = 1e-6 * kInv2Pi * bins;
  if (to_edge > margin && to_edge < 1.0 - margin && m < bins) return m;
  // The definition: phi = atan2(y, x) - phi_i reduced to [0, 2 pi), bin floor(phi / (2 pi) M).
  double phi = std::atan2(y, x) - phi_i;
  phi -= 2.0 * kPi * std::floor(phi / (2.0 * kPi));
  return std::clamp(static_cast<int>(phi / (2.0 * kPi) * bins), 0, bins - 1);
}

double BrdfTable::theta_centre_deg(int k) const {
  return std::acos((k + 0.5) / options.bins_theta) / kDegree;
}

double BrdfTable::phi_centre_deg(int m) const { return (m + 0.5) * 360.0 / options.bins_phi; }

double BrdfTable::projected_solid_angle(int k) const {
  const double lo = static_cast<double>(k) / options.bins_theta;
  const double hi = static_cast<double>(k + 1) / options.bins_theta;
  return 0.5 * (hi - lo) * (hi + lo) * (2.0 * kPi / options.bins_phi);
}

BrdfTable brdf_table_monte_carlo(const LayerStack& stack, const BrdfOptions& options) {
  BrdfTable table = empty_table(options);
  const glm::dvec3 wi = incident_direction(options.theta_i_deg, options.phi_i_deg);
  const double phi_i = options.phi_i_deg * kDegree;
  // Fresnel reflection at the top (exact, zero variance) and the analytic delta parts.
  const double r_top = fresnel_dielectric(wi.z, stack.above_ior, stack.layers[0].ior);
  const ZerothOrder zeroth = zeroth_order(stack, wi.z);
  const bool rough = stack.single_scattering_top();
  const RoughDielectric top = top_interface(stack);
  // Energy-conserving rough interfaces: the walk reflects the glossy lobe itself (an unscattered
  // exit at the top, WalkResult::entry_reflection), and the unscattered light that crosses rough
  // interfaces has no closed form: R_specular and T_ballistic are then the walks' unscattered exits.
  // Diffuse interfaces spread the unscattered light likewise; a diffuse top met from its dense
  // side reflects (diffusely) in the walk too.
  const bool microsurfaces = stack.energy_conserving_rough() || stack.any_diffuse_interface();
  const bool walk_specular = rough || microsurfaces;
  const bool walk_reflects_entry =
      stack.energy_conserving_alpha(0) > 0.0 || (stack.diffuse_interface(0) && stack.above_ior > stack.layers[0].ior);
  const double top_specular_smooth = walk_reflects_entry ? 0.0 : r_top;
  const std::size_t nb = table.value.size();
  // Layout: totals [slot][channel][sum, sum2], ends, then bins [bin][channel][sum, sum2, single,
  // single2].
  const std::size_t totals_at = 0, ends_at = kTotalSlots * kChannels * 2, bins_at = ends_at + kEndKinds + 1;
  const std::size_t size = bins_at + nb * kChannels * 4;
  // A grey stack's walks carry equal channels: tally channel 0 only and copy it at the end.
  const bool grey = stack.grey();
  const int tallied = grey ? 1 : kChannels;

  std::vector<double> bin_scale(options.bins_theta);  // 1 / projected solid angle of a bin in row k
  for (int k = 0; k < options.bins_theta; ++k) bin_scale[k] = 1.0 / table.projected_solid_angle(k);
  WalkPlan plan;  // once for all photons: a thin slab's walk is only a few events long
  prepare_walk(stack, options.walk, &plan);

  std::vector<double> acc = run_photons(options.samples, size, [&](std::uint64_t i, std::vector<double>& a) {
    Rng rng(options.seed, i);
    const WalkResult walk = random_walk(plan, wi, rng);
    // A rough top reflects into a glossy lobe, not a delta: its energy by one sample of the
    // facets per photon (visible normals; weight F G2/G1, 0 below the facets). It is a total
    // only: the table's bins hold the light that entered the stack.
    double glossy = 0.0;
    if (rough) {
      const double u0 = rng.uniform(), u1 = rng.uniform();
      glm::dvec3 r;
      if (!top.sample_reflection(wi, {u0, u1}, &r, &glossy)) glossy = 0.0;
    }
    // Unscattered exits leave in the mirror / ballistic direction: delta parts, not diffuse.
    const bool delta = walk.scatter_count == 0;
    const bool at_top = walk.side == WalkResult::Side::Top, at_bottom = walk.side == WalkResult::Side::Bottom;
    // The photon's value of every slot, channel by channel (a grey stack's: channel 0 only),
    // each assigned once: zeroing an array of slots per photon and adding into it was a visible
    // share of a thin slab's photon.
    for (int c = 0; c < tallied; ++c) {
      const double w = walk.weight[c];
      double x[kTotalSlots];
      // Rough: R_specular is this photon's estimate too, so it takes the unscattered exits (light
      // reflected by an inner interface) that the smooth case has in zeroth_order's closed form.
      const double top_specular = rough ? glossy : top_specular_smooth;  // what the walk does not reflect
      x[kRs] = walk_specular ? top_specular + (delta && at_top ? w : 0.0) : zeroth.R_specular[c];
      x[kRd] = at_top && !delta ? w : 0.0;
      x[kTb] = microsurfaces ? (delta && at_bottom ? w : 0.0) : zeroth.T_ballistic[c];
      x[kTd] = at_bottom && !delta ? w : 0.0;
      // Conservation by construction: this photon's absorbed part is what did not leave.
      x[kAbs] = 1.0 - x[kRs] - x[kRd] - x[kTb] - x[kTd];
      x[kAbsDirect] = walk.absorbed[c];
      x[kRsWalk] = top_specular + (delta && at_top ? w : 0.0);
      x[kTbWalk] = delta && at_bottom ? w : 0.0;
      x[kUnresolved] = walk.cut_weight[c];
      for (int s = 0; s < kTotalSlots; ++s) {
        // The ballistic transmission, and the specular reflection of a smooth top, are reported
        // from their closed forms below, not from these sums.
        if ((s == kTb && !microsurfaces) || (s == kRs && !walk_specular)) continue;
        a[totals_at + (s * kChannels + c) * 2] += x[s];
        a[totals_at + (s * kChannels + c) * 2 + 1] += x[s] * x[s];
      }
    }
    a[ends_at + static_cast<int>(walk.end)] += 1.0;
    if (!walk.cut_weight.is_black()) a[ends_at + kEndKinds] += 1.0;
    if (!delta && walk.side != WalkResult::Side::None) {
      int k;
      const int b = bin_of(table, walk.direction, phi_i, &k);
      if (b >= 0) {
        const double scale = bin_scale[k];
        for (int c = 0; c < tallied; ++c) {
          const double v = walk.weight[c] * scale;
          double* slot = &a[bins_at + (b * kChannels + c) * 4];
          slot[0] += v;
          slot[1] += v * v;
          if (walk.scatter_count == 1) {
            slot[2] += v;
            slot[3] += v * v;
          }
        }
      }
    }
  }, options.on_progress);
  if (grey) {
    for (int s = 0; s < kTotalSlots; ++s)
      for (int c = 1; c < kChannels; ++c)
        for (int m = 0; m < 2; ++m) acc[totals_at + (s * kChannels + c) * 2 + m] = acc[totals_at + s * kChannels * 2 + m];
    for (std::size_t b = 0; b < nb; ++b)
      for (int c = 1; c < kChannels; ++c)
        for (int m = 0; m < 4; ++m) acc[bins_at + (b * kChannels + c) * 4 + m] = acc[bins_at + b * kChannels * 4 + m];
  }

  const std::uint64_t n = options.samples;
  Estimate* totals[kTotalSlots] = {&table.totals.R_specular, &table.totals.R_diffuse,
                                   &table.totals.T_ballistic, &table.totals.T_diffuse,
                                   &table.totals.absorbed, &table.totals.absorbed_direct,
                                   &table.totals.R_specular_walk, &table.totals.T_ballistic_walk,
                                   &table.totals.unresolved};
  for (int s = 0; s < kTotalSlots; ++s)
    for (int c = 0; c < kChannels; ++c)
      mean_and_error(acc[totals_at + (s * kChannels + c) * 2], acc[totals_at + (s * kChannels + c) * 2 + 1],
                     n, &totals[s]->value[c], &totals[s]->stderr_[c]);
  // The analytic parts are the same for every photon: report them exactly (no summation error).
  if (!walk_specular) table.totals.R_specular = {zeroth.R_specular, Spectrum(0.0)};
  if (!microsurfaces) table.totals.T_ballistic = {zeroth.T_ballistic, Spectrum(0.0)};
  for (int e = 0; e < kEndKinds; ++e) table.ends[e] = static_cast<std::uint64_t>(acc[ends_at + e]);
  table.totals.unresolved_walks = static_cast<std::uint64_t>(acc[ends_at + kEndKinds]);
  for (std::size_t b = 0; b < nb; ++b)
    for (int c = 0; c < kChannels; ++c) {
      const double* slot = &acc[bins_at + (b * kChannels + c) * 4];
      mean_and_error(slot[0], slot[1], n, &table.value[b][c], &table.stderr_[b][c]);
      mean_and_error(slot[2], slot[3], n, &table.single[b][c], &table.single_stderr[b][c]);
      table.multiple[b][c] = table.value[b][c] - table.single[b][c];
    }
  return table;
}

BrdfTable brdf_table_first_order(const LayerStack& stack, const BrdfOptions& options, int n, bool diffuse_totals) {
  BrdfTable table = empty_table(options);
  const glm::dvec3 wi = incident_direction(options.theta_i_deg, options.phi_i_deg);
  const double phi_i = options.phi_i_deg * kDegree;
  const int K = options.bins_theta, M = options.bins_phi;
  // Bin average weighted by projected solid angle: with x = mu^2 (dx = 2 mu dmu, so
  // mu dmu dphi = dx dphi / 2) the weight is uniform in (x, phi): Gauss-Legendre in x on
  // [lo^2, hi^2] and the midpoint rule in phi, normalised by the bin's area in (x, phi).

  // Everything but the phase functions depends on the cosines alone (first_order_cosines):
  // prepared once per cosine node of a bin row, for all its azimuths. A stack that does not
  // transmit has no transmission bins to evaluate (first_order_btdf is 0).
  tbb::parallel_for(tbb::blocked_range<int>(0, 2 * K), [&](const tbb::blocked_range<int>& range) {
    std::vector<double> nodes(n), weights(n);
    std::vector<FirstOrderCosines> cosines(n);
    for (int sk = range.begin(); sk != range.end(); ++sk) {
      const int side = sk / K, k = sk % K;
      if (side == 1 && !stack.transmits()) continue;  // the table's bins are 0 already
      const double lo = static_cast<double>(k) / K, hi = static_cast<double>(k + 1) / K;
      gauss_legendre(n, lo * lo, hi * hi, nodes.data(), weights.data());
      for (int a = 0; a < n; ++a) {
        const double mu = std::sqrt(nodes[a]);
        cosines[a] = first_order_cosines(stack, wi.z, side == 0 ? mu : -mu);
      }
      for (int m = 0; m < M; ++m) {
        Spectrum sum;
        for (int a = 0; a < n; ++a) {
          const double mu = std::sqrt(nodes[a]);
          const double sin_t = std::sqrt(std::max(0.0, (1.0 - mu) * (1.0 + mu)));
          for (int b = 0; b < n; ++b) {
            const double phi = phi_i + 2.0 * kPi * (m + (b + 0.5) / n) / M;
            const glm::dvec3 wo{sin_t * std::cos(phi), sin_t * std::sin(phi), side == 0 ? mu : -mu};
            sum += first_order_bsdf(stack, cosines[a], wi, wo) * (weights[a] / n);
          }
        }
        const int idx = table.bin_index(static_cast<BrdfSide>(side), k, m);
        table.value[idx] = table.single[idx] = sum / ((hi - lo) * (hi + lo));
      }
    }
  });
  const ZerothOrder zeroth = zeroth_order(stack, wi.z);
  const FirstOrderAlbedo albedo = diffuse_totals ? first_order_albedo(stack, wi.z) : FirstOrderAlbedo{};
  table.totals.R_specular.value = zeroth.R_specular;
  table.totals.T_ballistic.value = zeroth.T_ballistic;
  table.totals.R_diffuse.value = albedo.R_diffuse;
  table.totals.T_diffuse.value = albedo.T_diffuse;
  table.totals.absorbed.value = Spectrum(1.0) - zeroth.R_specular - zeroth.T_ballistic - albedo.R_diffuse - albedo.T_diffuse;
  return table;
}

namespace {
// A connection target in the walk's stack and, with the similarity switch, in its similar stack.
struct SwitchedTarget {
  ConnectionTarget own, similar;
};
SwitchedTarget prepare_switched_target(const LayerStack& stack, const WalkOptions& settings, const glm::dvec3& w) {
  SwitchedTarget t;
  t.own = prepare_connection(stack, w);
  if (settings.similar && settings.similarity_after >= 0) t.similar = prepare_connection(*settings.similar, w);
  return t;
}
// An event's connection through the stack it scattered in (stack_of_event).
Spectrum switched_connection(const LayerStack& stack, const WalkOptions& settings, const ScatterEvent& event,
                             const SwitchedTarget& target) {
  const LayerStack& s = stack_of_event(stack, settings, event);
  return connection_weight_all_paths(s, event, &s == &stack ? target.own : target.similar);
}
}  // namespace

std::vector<PointEstimate> brdf_connection_estimate(const LayerStack& stack, const glm::dvec3& wi,
                                                    const std::vector<glm::dvec3>& wo,
                                                    std::uint64_t samples, std::uint64_t seed,
                                                    const WalkOptions& walk_settings) {
  const std::size_t nd = wo.size();
  std::vector<SwitchedTarget> targets;
  for (const glm::dvec3& w : wo) targets.push_back(prepare_switched_target(stack, walk_settings, w));
  // Layout: [direction][channel][sum, sum2, single sum, single sum2].
  const std::vector<double> acc = run_photons(samples, nd * kChannels * 4, [&](std::uint64_t i, std::vector<double>& a) {
    Rng rng(seed, i);
    std::vector<Spectrum> total(nd), single(nd);
    random_walk(stack, wi, rng, [&](const ScatterEvent& event) {
      for (std::size_t j = 0; j < nd; ++j) {
        const Spectrum v = event.throughput * switched_connection(stack, walk_settings, event, targets[j]);
        total[j] += v;
        if (event.order == 1) single[j] += v;
      }
    }, walk_settings);
    for (std::size_t j = 0; j < nd; ++j)
      for (int c = 0; c < kChannels; ++c) {
        double* slot = &a[(j * kChannels + c) * 4];
        slot[0] += total[j][c];
        slot[1] += total[j][c] * total[j][c];
        slot[2] += single[j][c];
        slot[3] += single[j][c] * single[j][c];
      }
  });
  std::vector<PointEstimate> out(nd);
  for (std::size_t j = 0; j < nd; ++j)
    for (int c = 0; c < kChannels; ++c) {
      const double* slot = &acc[(j * kChannels + c) * 4];
      mean_and_error(slot[0], slot[1], samples, &out[j].total.value[c], &out[j].total.stderr_[c]);
      mean_and_error(slot[2], slot[3], samples, &out[j].single.value[c], &out[j].single.stderr_[c]);
    }
  return out;
}

BrdfTable brdf_table_connection(const LayerStack& stack, const BrdfOptions& options) {
  BrdfTable table = empty_table(options);
  const glm::dvec3 wi = incident_direction(options.theta_i_deg, options.phi_i_deg);
  const double phi_i = options.phi_i_deg * kDegree;
  const int K = options.bins_theta, M = options.bins_phi;
  const std::size_t nb = table.value.size();
  // Layout: [bin][channel][sum, sum2, single].
  const std::vector<double> acc = run_photons(options.samples, nb * kChannels * 3, [&](std::uint64_t i, std::vector<double>& a) {
    Rng rng(options.seed, i);
    Rng directions(options.seed, i, 1);  // a separate stream: the walk is the same as the table's
    std::vector<Spectrum> total(nb), single(nb);
    // One direction per bin and photon, uniform in projected solid angle within the bin (mu^2
    // uniform in [lo^2, hi^2], phi uniform), drawn independently of the walk and shared by its
    // events: E over w of sum_e W_e c(w) = sum_e W_e (bin average of c), so unbiased.
    std::vector<SwitchedTarget> targets(nb);
    for (int side = 0; side < 2; ++side)
      for (int k = 0; k < K; ++k)
        for (int m = 0; m < M; ++m) {
          const double lo = static_cast<double>(k) / K, hi = static_cast<double>(k + 1) / K;
          const double mu = std::sqrt(lo * lo + directions.uniform() * (hi - lo) * (hi + lo));
          const double phi = phi_i + 2.0 * kPi * (m + directions.uniform()) / M;
          const double sin_t = std::sqrt(std::max(0.0, (1.0 - mu) * (1.0 + mu)));
          const glm::dvec3 w{sin_t * std::cos(phi), sin_t * std::sin(phi), side == 0 ? mu : -mu};
          targets[table.bin_index(static_cast<BrdfSide>(side), k, m)] = prepare_switched_target(stack, options.walk, w);
        }
    random_walk(stack, wi, rng, [&](const ScatterEvent& event) {
      for (std::size_t b = 0; b < nb; ++b) {
        const Spectrum v = event.throughput * switched_connection(stack, options.walk, event, targets[b]);
        total[b] += v;
        if (event.order == 1) single[b] += v;
      }
    }, options.walk);
    for (std::size_t b = 0; b < nb; ++b)
      for (int c = 0; c < kChannels; ++c) {
        double* slot = &a[(b * kChannels + c) * 3];
        slot[0] += total[b][c];
        slot[1] += total[b][c] * total[b][c];
        slot[2] += single[b][c];
      }
  });
  for (std::size_t b = 0; b < nb; ++b)
    for (int c = 0; c < kChannels; ++c) {
      const double* slot = &acc[(b * kChannels + c) * 3];
      mean_and_error(slot[0], slot[1], options.samples, &table.value[b][c], &table.stderr_[b][c]);
      table.single[b][c] = slot[2] / static_cast<double>(options.samples);
      table.multiple[b][c] = table.value[b][c] - table.single[b][c];
    }
  return table;
}

}  // namespace lamina
