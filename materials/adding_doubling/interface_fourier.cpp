// The projection of an interface's BSDF onto the solver's basis (interface_fourier.h).
//
// The solver (adding_doubling.cpp, 2. and 8.) carries, per azimuthal mode m, the power F_i of each
// discrete direction i, and a Fourier mode of radiance L = sum_m L_m(mu) cos(m dphi) (dphi the
// difference of the azimuths of travel). A surface of BSDF f scatters mode m as
//     L_m,out(mu) = 2 pi int f_m(mu, mu') L_m(mu') mu' dmu',
//     f_m(mu, mu') = (1/2 pi) int_0^2pi f(mu, mu', dphi) cos(m dphi) d dphi
// (the Fourier series of f in dphi; Jakob et al. 2014, eqs. 6-8, with our normalisation). A beam of
// unit power per unit area in direction j (the solver's column j) gives the outgoing radiance
// f_m(mu, mu_j), and the power it puts into the solid-angle cell of node i (the directions whose
// mu^2 lies in [x_lo, x_hi], all azimuths; its projected solid angle is pi (x_hi - x_lo) = pi W_i,
// the node's flux weight) is
//     M_ij = 2 pi int_cell f_m(mu, mu_j) mu dmu = int_cell mu dmu int_0^2pi f cos(m (phi - pi)) dphi,
// where phi is the azimuth of wo with wi at azimuth 0 (both pointing away, as in microfacet.h):
// the incoming light travels along -wi, azimuth pi, so dphi = phi - pi. f is even in phi, so
// the azimuthal integral is 2 int_0^pi, and mu dmu = dx/2 with x = mu^2.
// Integrating the outgoing side over the node's cell (rather than sampling f at the node) keeps
// the power of a glossy lobe narrower than the nodes' spacing: the column sums of mode 0 are the
// interface's albedo up to the cell quadrature, for any roughness, and as alpha -> 0 the cells
// of a Snell-invariant node set map onto themselves, so the matrices tend to the smooth
// interface's diagonal Fresnel operator.
// Quadrature: Gauss-Legendre in the polar angle per cell (cell_points); in phi, panels that halve
// towards the specular side phi = pi (reflection and refraction peak there), split where a
// refraction pair stops being possible (f jumps there: refraction_cuts), Gauss-Legendre in each
// (docs/adding_doubling.md, "Rough interfaces", for the convergence).
#include "materials/adding_doubling/interface_fourier.h"

#include <algorithm>
#include <cmath>
#include <list>
#include <tuple>
#include <memory>
#include <mutex>
#include <optional>

#include <tbb/parallel_for.h>

#include "materials/analytic/first_order.h"  // GaussLegendreRule
#include "materials/base/sampling.h"         // kPi
#include "materials/interfaces/microfacet.h"
#include "materials/interfaces/microsurface.h"
#include "materials/interfaces/microsurface_first_order.h"

namespace lamina {

double single_scattering_ggx_eval(double alpha, double n_above, double n_below, const glm::dvec3& wo,
                                  const glm::dvec3& wi) {
  return RoughDielectric{{alpha}, n_above, n_below}.eval(wo, wi);
}

double microsurface_single_eval(double alpha, double n_above, double n_below, const glm::dvec3& wo,
                                const glm::dvec3& wi) {
  return MicrosurfaceDielectric{{alpha}, n_above, n_below}.eval_single(wo, wi);
}

namespace {

// The azimuths (in (0, pi)) where f may jump: for a refraction pair the generalised half vector
// -(n_i wi + n_o wo) (Walter et al. 2007, eq. 16) turns perpendicular to wo or wi where
// wi.wo = -n_o/n_i or -n_i/n_o, and beyond that no facet refracts one into the other. wi.wo =
// s_i s_o cos(phi) + z_i z_o is monotone in phi, so each condition holds at one phi at most;
// panels split there integrate each smooth piece at the full Gauss-Legendre order.
int refraction_cuts(const glm::dvec3& wi, double sin_o, double z_o, double n_i, double n_o, double* cuts) {
  int n = 0;
  const double ss = wi.x * sin_o;
  if (!(ss > 0.0)) return 0;
  for (double c : {-n_o / n_i, -n_i / n_o}) {
    const double x = (c - wi.z * z_o) / ss;
    if (x > -1.0 && x < 1.0) cuts[n++] = std::acos(x);
  }
  return n;
}

// An interface's eval as a plain function (the projection cache and the fast path of the
// microsurface know it by its address).
using EvalFunction = double (*)(double, double, double, const glm::dvec3&, const glm::dvec3&);

// One block: light arriving on side in_sign (+1 above, -1 below) leaving on side out_sign.
std::vector<std::vector<double>> project_block(double alpha, double n_above, double n_below, const InterfaceEval& eval,
                                               const FourierDirections& in, double in_sign,
                                               const FourierDirections& out, double out_sign, int modes,
                                               const InterfaceProjectionSettings& s) {
  const int rows = out.size(), cols = in.size();
  std::vector<std::vector<double>> block(modes, std::vector<double>(static_cast<std::size_t>(rows) * cols, 0.0));
  // The azimuth panels: halving towards pi (the specular side).
  // The panels halve until the last is at most alpha/4 wide (the lobes' azimuthal width is
  // ~alpha / sin(theta)), at least 3 and at most phi_panels.
  const int panels = std::clamp(1 + static_cast<int>(std::ceil(std::log2(4.0 * kPi / alpha))), 3, s.phi_panels);
  std::vector<double> edges{0.0};
  for (int p = 1; p < panels; ++p) edges.push_back(kPi * (1.0 - std::ldexp(1.0, -p)));
  edges.push_back(kPi);
  const bool refraction = in_sign != out_sign;
  const double n_in = in_sign > 0.0 ? n_above : n_below, n_out = out_sign > 0.0 ? n_above : n_below;
  const GaussLegendreRule cell_rule(s.cell_points), phi_rule(s.phi_points);
  const GaussLegendreRule input_rule(s.input_points);
  // The microsurface's first order is evaluated through its per-direction form (the terms of wi
  // once per beam, the Beta function once per polar angle): the same numbers, fewer of its
  // special functions.
  const EvalFunction* function = eval.target<EvalFunction>();
  const bool microsurface = function && *function == microsurface_single_eval;
  tbb::parallel_for(0, cols, [&](int j) {
    if (!(in.mu[j] > 0.0)) return;
    std::vector<double> x(s.cell_points), w(s.cell_points), px(s.phi_points), pw(s.phi_points);
    std::vector<double> panel, cuts, sum(modes);
    // The incoming directions: the node's own (a beam: a node of weight zero), or its cell's,
    // averaged with the weight mu dmu (light spread evenly over the cell in projected solid
    // angle), so that both sides are integrated over their cells and the power exchanged
    // between two cells is the same integral read either way (reciprocity).
    std::vector<double> in_mu{in.mu[j]}, in_w{1.0};
    if (in.x_hi[j] > in.x_lo[j]) {
      const double lo = std::acos(std::sqrt(std::min(1.0, in.x_hi[j]))), hi = std::acos(std::sqrt(std::min(1.0, in.x_lo[j])));
      in_mu.resize(s.input_points);
      in_w.resize(s.input_points);
      std::vector<double> t(s.input_points);
      input_rule.apply(lo, hi, t.data(), in_w.data());
      double total = 0.0;
      for (int q = 0; q < s.input_points; ++q) {
        in_mu[q] = std::cos(t[q]);
        in_w[q] *= in_mu[q] * std::sin(t[q]);
        total += in_w[q];
      }
      for (double& v : in_w) v /= total;
    }
    for (std::size_t beam = 0; beam < in_mu.size(); ++beam) {
    const double mu_j = in_mu[beam], beam_weight = in_w[beam];
    const glm::dvec3 wi{std::sqrt(std::max(0.0, (1.0 - mu_j) * (1.0 + mu_j))), 0.0, in_sign * mu_j};
    std::optional<MicrosurfaceFirstOrder> first;
    if (microsurface) first.emplace(MicrosurfaceDielectric{{alpha}, n_above, n_below}, wi);
    // The direction a smooth interface would send wi to (-1: none, total internal reflection).
    const double sin_image = refraction ? n_in / n_out * wi.x : wi.x;
    const double theta_image = sin_image < 1.0 ? std::asin(sin_image) : -1.0;
    for (int i = 0; i < rows; ++i) {
      if (!(out.x_hi[i] > out.x_lo[i])) continue;
      // In the polar angle: f mu sin(theta) is bounded at grazing (f ~ 1/mu there, where the
      // measure in x = mu^2 is not), and a lobe around the pole is resolved in angle, not in mu.
      const double theta_lo = std::acos(std::sqrt(std::min(1.0, out.x_hi[i])));
      const double theta_hi = std::acos(std::sqrt(std::min(1.0, out.x_lo[i])));
      // A refraction pair's half vector is horizontal where n_o mu_o = n_i mu_i, and the
      // microsurface has no facet there: f jumps from D's horizontal limit to 0 (the generalised
      // half vector leaves the upper hemisphere). The cell is split at that polar angle.
      // Near the smooth interface's image of wi (theta_image) the lobe is about alpha wide, which
      // a cell may not resolve (the top cell spans ~13 degrees at 16 points): the cell is also
      // split at theta_image +- alpha (1/8 .. 2), graded towards the peak.
      std::vector<double>& pieces = cuts;
      pieces.assign({theta_lo, theta_hi});
      auto cut_at = [&](double theta) {
        if (theta > theta_lo && theta < theta_hi) pieces.push_back(theta);
      };
      if (refraction && n_in * mu_j / n_out < 1.0) cut_at(std::acos(n_in * mu_j / n_out));
      if (theta_image >= 0.0)
        for (double k : {0.0, 0.125, 0.25, 0.5, 1.0, 2.0}) {
          cut_at(theta_image - k * alpha);
          cut_at(theta_image + k * alpha);
        }
      std::sort(pieces.begin(), pieces.end());
      const int n_pieces = static_cast<int>(pieces.size()) - 1;
      for (int piece = 0; piece < n_pieces; ++piece) {
      if (!(pieces[piece + 1] > pieces[piece])) continue;
      cell_rule.apply(pieces[piece], pieces[piece + 1], x.data(), w.data());
      for (int q = 0; q < s.cell_points; ++q) {
        const double mu = std::cos(x[q]), sin_o = std::sin(x[q]);
        const double measure = w[q] * mu * sin_o;  // mu dmu = mu sin(theta) dtheta
        panel = edges;
        if (refraction) {
          double cuts[2];
          const int n = refraction_cuts(wi, sin_o, out_sign * mu, n_in, n_out, cuts);
          panel.insert(panel.end(), cuts, cuts + n);
          std::sort(panel.begin(), panel.end());
        }
        std::fill(sum.begin(), sum.end(), 0.0);
        for (std::size_t p = 0; p + 1 < panel.size(); ++p) {
          if (!(panel[p + 1] > panel[p])) continue;
          phi_rule.apply(panel[p], panel[p + 1], px.data(), pw.data());
          for (int k = 0; k < s.phi_points; ++k) {
            const double c = std::cos(px[k]);
            const glm::dvec3 wo{sin_o * c, sin_o * std::sin(px[k]), out_sign * mu};
            const double f = first ? first->eval(wo) : eval(alpha, n_above, n_below, wo, wi);
            if (f == 0.0) continue;
            // 2 (-1)^m cos(m phi) by the Chebyshev recurrence cos(m phi) = 2 c cos((m-1) phi) - cos((m-2) phi).
            double prev = 1.0, cur = c;
            const double v = 2.0 * f * pw[k];
            sum[0] += v;
            for (int m = 1; m < modes; ++m) {
              sum[m] += (m % 2 ? -v : v) * cur;
              const double next = 2.0 * c * cur - prev;
              prev = cur;
              cur = next;
            }
          }
        }
        for (int m = 0; m < modes; ++m) block[m][static_cast<std::size_t>(i) * cols + j] += beam_weight * measure * sum[m];
      }
      }
    }
    }
  });
  return block;
}

}  // namespace

namespace {

InterfaceFourier project(double alpha, double n_above, double n_below, const InterfaceEval& eval,
                         const FourierDirections& above, const FourierDirections& below, int modes,
                         const InterfaceProjectionSettings& settings) {
  InterfaceFourier out;
  out.modes = modes;
  out.above = above.size();
  out.below = below.size();
  out.Rt = project_block(alpha, n_above, n_below, eval, above, 1.0, above, 1.0, modes, settings);
  out.Td = project_block(alpha, n_above, n_below, eval, above, 1.0, below, -1.0, modes, settings);
  out.Rb = project_block(alpha, n_above, n_below, eval, below, -1.0, below, -1.0, modes, settings);
  out.Tu = project_block(alpha, n_above, n_below, eval, below, -1.0, above, 1.0, modes, settings);
  return out;
}

// The last projections made, by their exact inputs: a scene's table set projects the same top
// on the same nodes for every table along a parameter that is not the roughness, and the table
// mode's auto prediction again. A hit returns the same numbers a new projection would.
struct CacheKey {
  double alpha, n_above, n_below;
  int modes, cell_points, input_points, phi_panels, phi_points;
  EvalFunction eval;
  bool multiple;  // project_microsurface (walks, seed: its higher orders)
  int walks;
  std::uint64_t seed;
  std::vector<double> above_mu, above_lo, above_hi, below_mu, below_lo, below_hi;
  // Serves `o`: the same inputs, and at least o's modes (mode m's numbers do not depend on how
  // many modes are projected, so the first o.modes of a larger projection are o's projection).
  bool serves(const CacheKey& o) const {
    return alpha == o.alpha && n_above == o.n_above && n_below == o.n_below && modes >= o.modes &&
           cell_points == o.cell_points && input_points == o.input_points && phi_panels == o.phi_panels &&
           phi_points == o.phi_points && eval == o.eval && multiple == o.multiple && walks == o.walks &&
           seed == o.seed && above_mu == o.above_mu && above_lo == o.above_lo &&
           above_hi == o.above_hi && below_mu == o.below_mu && below_lo == o.below_lo && below_hi == o.below_hi;
  }
};
constexpr std::size_t kCacheSize = 8;
std::mutex cache_mutex;
std::list<std::pair<CacheKey, std::shared_ptr<const InterfaceFourier>>> cache;  // most recent first

// A projection by its exact inputs from the cache, or made by `make` and stored.
template <class Make>
InterfaceFourier cached(CacheKey key, Make make) {
  {
    std::lock_guard<std::mutex> lock(cache_mutex);
    for (auto it = cache.begin(); it != cache.end(); ++it)
      if (it->first.serves(key)) {
        cache.splice(cache.begin(), cache, it);
        InterfaceFourier out = *cache.front().second;
        out.modes = key.modes;
        for (auto* b : {&out.Rt, &out.Td, &out.Rb, &out.Tu, &out.Rt_single, &out.Td_single})
          if (static_cast<int>(b->size()) > key.modes) b->resize(key.modes);
        return out;
      }
  }
  auto made = std::make_shared<const InterfaceFourier>(make());
  std::lock_guard<std::mutex> lock(cache_mutex);
  cache.emplace_front(std::move(key), made);
  if (cache.size() > kCacheSize) cache.pop_back();
  return *made;
}

CacheKey key_of(double alpha, double n_above, double n_below, EvalFunction eval, bool multiple,
                const FourierDirections& above, const FourierDirections& below, int modes,
                const InterfaceProjectionSettings& s) {
  return CacheKey{alpha, n_above, n_below, modes, s.cell_points, s.input_points, s.phi_panels, s.phi_points,
                  eval, multiple, multiple ? s.walks : 0, multiple ? s.seed : 0, above.mu, above.x_lo, above.x_hi,
                  below.mu, below.x_lo, below.x_hi};
}

}  // namespace

InterfaceFourier project_interface(double alpha, double n_above, double n_below, const InterfaceEval& eval,
                                   const FourierDirections& above, const FourierDirections& below, int modes,
                                   const InterfaceProjectionSettings& settings) {
  // Only a plain function is known by its address; anything else is projected every time.
  const EvalFunction* function = eval.target<EvalFunction>();
  if (!function) return project(alpha, n_above, n_below, eval, above, below, modes, settings);
  return cached(key_of(alpha, n_above, n_below, *function, false, above, below, modes, settings),
                [&] { return project(alpha, n_above, n_below, eval, above, below, modes, settings); });
}

}  // namespace lamina

namespace lamina {

BeamFourier project_beams(double alpha, double n_above, double n_below, const InterfaceEval& eval,
                          const FourierDirections& beams, const FourierDirections& above,
                          const FourierDirections& below, int modes, const InterfaceProjectionSettings& settings) {
  BeamFourier out;
  out.modes = modes;
  out.beams = beams.size();
  out.Rt = project_block(alpha, n_above, n_below, eval, beams, 1.0, above, 1.0, modes, settings);
  out.Td = project_block(alpha, n_above, n_below, eval, beams, 1.0, below, -1.0, modes, settings);
  return out;
}

namespace {

// The cells of one side sorted by their lower end, to find the cell of an outgoing mu^2.
struct CellIndex {
  std::vector<double> lo;
  std::vector<int> node;
  explicit CellIndex(const FourierDirections& d) {
    std::vector<int> order;
    for (int i = 0; i < d.size(); ++i)
      if (d.x_hi[i] > d.x_lo[i]) order.push_back(i);
    std::sort(order.begin(), order.end(), [&](int a, int b) { return d.x_lo[a] < d.x_lo[b]; });
    for (int i : order) {
      lo.push_back(d.x_lo[i]);
      node.push_back(i);
    }
  }
  int find(double x) const {
    if (lo.empty()) return -1;
    const auto it = std::upper_bound(lo.begin(), lo.end(), x);
    return node[std::max<std::ptrdiff_t>(0, (it - lo.begin()) - 1)];
  }
};

using Blocks = std::vector<std::vector<double>>;  // [mode][i * columns + j]

// The orders >= 2 of the columns `in` (side in_sign): into H_R (cells of the same side) and H_T
// (the other side), M_ij(m) = E[1{to in cell i} cos(m (phi - pi))] over the walks of order
// >= 2 (phi the azimuth of the exit from the arrival's: the moments of project_block, since the
// walk's density P(to | from) = f |to.z| is the cells' measure).
void walk_higher_orders(const MicrosurfaceDielectric& surface, const FourierDirections& in, double in_sign,
                        const FourierDirections& same, const FourierDirections& other, int modes,
                        const InterfaceProjectionSettings& s, std::uint64_t stream, Blocks* H_R, Blocks* H_T) {
  const int cols = in.size(), n_same = same.size(), n_other = other.size();
  H_R->assign(modes, std::vector<double>(static_cast<std::size_t>(n_same) * cols, 0.0));
  H_T->assign(modes, std::vector<double>(static_cast<std::size_t>(n_other) * cols, 0.0));
  const CellIndex same_cells(same), other_cells(other);
  tbb::parallel_for(0, cols, [&](int j) {
    if (!(in.mu[j] > 0.0)) return;
    Rng rng(s.seed, stream, static_cast<std::uint64_t>(j));
    const bool cell = in.x_hi[j] > in.x_lo[j];
    const double weight = 1.0 / s.walks;
    for (int k = 0; k < s.walks; ++k) {
      // Stratified over the cell uniformly in mu^2 (projected solid angle): the incoming power
      // spread evenly over it, as project_block's input average.
      const double x = cell ? in.x_lo[j] + (in.x_hi[j] - in.x_lo[j]) * (k + rng.uniform()) / s.walks : in.mu[j] * in.mu[j];
      const double mu = std::sqrt(std::clamp(x, 0.0, 1.0));
      const glm::dvec3 from{std::sqrt(std::max(0.0, (1.0 - mu) * (1.0 + mu))), 0.0, in_sign * mu};
      glm::dvec3 to;
      int order = 0;
      if (!surface.sample(from, rng, &to, &order) || order < 2) continue;
      const bool reflected = to.z * in_sign > 0.0;
      const int i = (reflected ? same_cells : other_cells).find(to.z * to.z);
      if (i < 0) continue;
      Blocks& block = reflected ? *H_R : *H_T;
      const std::size_t at = static_cast<std::size_t>(i) * cols + j;
      const double st = std::sqrt(to.x * to.x + to.y * to.y);
      const double c = st > 0.0 ? to.x / st : 1.0;
      // (-1)^m cos(m phi) by the Chebyshev recurrence, as project_block.
      double prev = 1.0, cur = c;
      block[0][at] += weight;
      for (int m = 1; m < modes; ++m) {
        block[m][at] += (m % 2 ? -cur : cur) * weight;
        const double next = 2.0 * c * cur - prev;
        prev = cur;
        cur = next;
      }
    }
  });
}

// The energy step: the interface loses nothing, so each column of the first order (R, T) plus
// the higher orders (H_R, H_T) sums to 1 in mode 0; the higher orders' column is scaled to make
// it so (every mode by the same factor). Returns the largest |1 - first - higher| before.
double conserve_energy(const Blocks& R, const Blocks& T, Blocks* H_R, Blocks* H_T, int cols, InterfaceFourier* check) {
  const std::size_t n_same = R[0].size() / std::max(1, cols), n_other = T[0].size() / std::max(1, cols);
  double largest = 0.0;
  for (int j = 0; j < cols; ++j) {
    double first = 0.0, higher = 0.0;
    for (std::size_t i = 0; i < n_same; ++i) {
      first += R[0][i * cols + j];
      higher += (*H_R)[0][i * cols + j];
    }
    for (std::size_t i = 0; i < n_other; ++i) {
      first += T[0][i * cols + j];
      higher += (*H_T)[0][i * cols + j];
    }
    if (!(first > 0.0) && !(higher > 0.0)) continue;  // a column of no direction
    largest = std::max(largest, std::abs(1.0 - first - higher));
    if (check) {
      check->smallest_single_albedo = std::min(check->smallest_single_albedo, first);
      check->largest_single_albedo = std::max(check->largest_single_albedo, first);
    }
    const double scale = higher > 0.0 ? std::max(0.0, 1.0 - first) / higher : 0.0;
    for (auto* H : {H_R, H_T})
      for (auto& mode : *H)
        for (std::size_t i = 0; i < mode.size() / cols; ++i) mode[i * cols + j] *= scale;
  }
  return largest;
}

// Reciprocity of the higher orders, which their walks hold only in the mean: the power exchanged
// between two cells under uniform radiance, n_j^2 W_j M_ij (W the cell's measure in mu^2, n the
// index on the arrival's side: f(wo, wi) / n_o^2 = f(wi, wo) / n_i^2), is the same read either
// way; each pair's two estimates are replaced by their mean (which also halves their variance).
void symmetrise(const FourierDirections& a, const FourierDirections& b, double n_a, double n_b, Blocks* Ra, Blocks* Tab,
                Blocks* Rb, Blocks* Tba) {
  const int na = a.size(), nb = b.size();
  auto W = [](const FourierDirections& d, int i) { return d.x_hi[i] - d.x_lo[i]; };
  for (std::size_t m = 0; m < Ra->size(); ++m) {
    for (auto [R, d, n] : {std::tuple{Ra, &a, na}, std::tuple{Rb, &b, nb}})
      for (int i = 0; i < n; ++i)
        for (int j = i + 1; j < n; ++j) {
          double& x = (*R)[m][static_cast<std::size_t>(i) * n + j];
          double& y = (*R)[m][static_cast<std::size_t>(j) * n + i];
          const double wi = W(*d, i), wj = W(*d, j);
          if (!(wi > 0.0) || !(wj > 0.0)) continue;
          const double mean = 0.5 * (wj * x + wi * y);
          x = mean / wj;
          y = mean / wi;
        }
    // Td: a (column j) -> b (row i), na x ... rows nb; Tu: b (column i) -> a (row j).
    for (int i = 0; i < nb; ++i)
      for (int j = 0; j < na; ++j) {
        double& x = (*Tab)[m][static_cast<std::size_t>(i) * na + j];
        double& y = (*Tba)[m][static_cast<std::size_t>(j) * nb + i];
        const double wx = n_a * n_a * W(a, j), wy = n_b * n_b * W(b, i);
        if (!(wx > 0.0) || !(wy > 0.0)) continue;
        const double mean = 0.5 * (wx * x + wy * y);
        x = mean / wx;
        y = mean / wy;
      }
  }
}

void add_to(Blocks* x, const Blocks& y) {
  for (std::size_t m = 0; m < x->size(); ++m)
    for (std::size_t k = 0; k < (*x)[m].size(); ++k) (*x)[m][k] += y[m][k];
}

}  // namespace

InterfaceFourier project_microsurface(double alpha, double n_above, double n_below, const FourierDirections& above,
                                      const FourierDirections& below, int modes, const InterfaceProjectionSettings& settings) {
  return cached(key_of(alpha, n_above, n_below, microsurface_single_eval, true, above, below, modes, settings), [&] {
    InterfaceFourier out = project(alpha, n_above, n_below, microsurface_single_eval, above, below, modes, settings);
    out.Rt_single = out.Rt;
    out.Td_single = out.Td;
    const MicrosurfaceDielectric surface{{alpha}, n_above, n_below};
    Blocks Rt, Td, Rb, Tu;
    walk_higher_orders(surface, above, 1.0, above, below, modes, settings, 1, &Rt, &Td);
    walk_higher_orders(surface, below, -1.0, below, above, modes, settings, 2, &Rb, &Tu);
    // Energy (exact) and reciprocity (in the mean) alternately, energy last: the columns sum to 1
    // and the pairs are reciprocal to far below the walks' noise after a few rounds.
    out.largest_energy_correction = std::max(conserve_energy(out.Rt, out.Td, &Rt, &Td, above.size(), &out),
                                        conserve_energy(out.Rb, out.Tu, &Rb, &Tu, below.size(), &out));
    for (int round = 0; round < 4; ++round) {
      symmetrise(above, below, n_above, n_below, &Rt, &Td, &Rb, &Tu);
      conserve_energy(out.Rt, out.Td, &Rt, &Td, above.size(), nullptr);
      conserve_energy(out.Rb, out.Tu, &Rb, &Tu, below.size(), nullptr);
    }
    add_to(&out.Rt, Rt);
    add_to(&out.Td, Td);
    add_to(&out.Rb, Rb);
    add_to(&out.Tu, Tu);
    return out;
  });
}

BeamFourier project_microsurface_beams(double alpha, double n_above, double n_below, const FourierDirections& beams,
                                       const FourierDirections& above, const FourierDirections& below, int modes,
                                       const InterfaceProjectionSettings& settings) {
  BeamFourier out = project_beams(alpha, n_above, n_below, microsurface_single_eval, beams, above, below, modes, settings);
  out.Rt_single = out.Rt;
  // The higher orders are smooth in the incidence: a beam's are interpolated, linearly in mu^2,
  // between the columns of the two cells around it (the nodes' projection, cached: its walks
  // are made once per interface and basis), then its column is made to sum to 1 as the nodes'.
  const InterfaceFourier nodes = project_microsurface(alpha, n_above, n_below, above, below, modes, settings);
  const int na = above.size(), nb_rows = below.size(), cols = beams.size();
  std::vector<std::pair<double, int>> centres;  // cell midpoints in mu^2, ascending
  for (int j = 0; j < na; ++j)
    if (above.x_hi[j] > above.x_lo[j]) centres.push_back({0.5 * (above.x_lo[j] + above.x_hi[j]), j});
  std::sort(centres.begin(), centres.end());
  if (centres.empty()) return out;
  for (int k = 0; k < cols; ++k) {
    const double x = beams.mu[k] * beams.mu[k];
    std::size_t hi = std::upper_bound(centres.begin(), centres.end(), std::make_pair(x, -1)) - centres.begin();
    const std::size_t lo = hi == 0 ? 0 : hi - 1;
    hi = std::min(hi, centres.size() - 1);
    const double t = hi == lo ? 0.0 : std::clamp((x - centres[lo].first) / (centres[hi].first - centres[lo].first), 0.0, 1.0);
    const int j0 = centres[lo].second, j1 = centres[hi].second;
    Blocks R1(modes, std::vector<double>(na)), T1(modes, std::vector<double>(nb_rows)), HR = R1, HT = T1;
    for (int m = 0; m < modes; ++m) {
      for (int i = 0; i < na; ++i) {
        const std::size_t a0 = static_cast<std::size_t>(i) * na + j0, a1 = static_cast<std::size_t>(i) * na + j1;
        R1[m][i] = out.Rt[m][static_cast<std::size_t>(i) * cols + k];
        HR[m][i] = (1.0 - t) * (nodes.Rt[m][a0] - nodes.Rt_single[m][a0]) + t * (nodes.Rt[m][a1] - nodes.Rt_single[m][a1]);
      }
      for (int i = 0; i < nb_rows; ++i) {
        const std::size_t a0 = static_cast<std::size_t>(i) * na + j0, a1 = static_cast<std::size_t>(i) * na + j1;
        T1[m][i] = out.Td[m][static_cast<std::size_t>(i) * cols + k];
        HT[m][i] = (1.0 - t) * (nodes.Td[m][a0] - nodes.Td_single[m][a0]) + t * (nodes.Td[m][a1] - nodes.Td_single[m][a1]);
      }
    }
    conserve_energy(R1, T1, &HR, &HT, 1, nullptr);
    for (int m = 0; m < modes; ++m) {
      for (int i = 0; i < na; ++i) out.Rt[m][static_cast<std::size_t>(i) * cols + k] += HR[m][i];
      for (int i = 0; i < nb_rows; ++i) out.Td[m][static_cast<std::size_t>(i) * cols + k] += HT[m][i];
    }
  }
  return out;
}

}  // namespace lamina
