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
#include <memory>
#include <mutex>

#include <tbb/parallel_for.h>

#include "materials/analytic/first_order.h"  // GaussLegendreRule
#include "materials/base/sampling.h"         // kPi
#include "materials/interfaces/microfacet.h"

namespace lamina {

double single_scattering_ggx_eval(double alpha, double n_above, double n_below, const glm::dvec3& wo,
                                  const glm::dvec3& wi) {
  return RoughDielectric{{alpha}, n_above, n_below}.eval(wo, wi);
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
            const double f = eval(alpha, n_above, n_below, {sin_o * c, sin_o * std::sin(px[k]), out_sign * mu}, wi);
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
using EvalFunction = double (*)(double, double, double, const glm::dvec3&, const glm::dvec3&);
struct CacheKey {
  double alpha, n_above, n_below;
  int modes, cell_points, input_points, phi_panels, phi_points;
  EvalFunction eval;
  std::vector<double> above_mu, above_lo, above_hi, below_mu, below_lo, below_hi;
  bool operator==(const CacheKey& o) const {
    return alpha == o.alpha && n_above == o.n_above && n_below == o.n_below && modes == o.modes &&
           cell_points == o.cell_points && input_points == o.input_points && phi_panels == o.phi_panels &&
           phi_points == o.phi_points && eval == o.eval && above_mu == o.above_mu && above_lo == o.above_lo &&
           above_hi == o.above_hi && below_mu == o.below_mu && below_lo == o.below_lo && below_hi == o.below_hi;
  }
};
constexpr std::size_t kCacheSize = 8;
std::mutex cache_mutex;
std::list<std::pair<CacheKey, std::shared_ptr<const InterfaceFourier>>> cache;  // most recent first

}  // namespace

InterfaceFourier project_interface(double alpha, double n_above, double n_below, const InterfaceEval& eval,
                                   const FourierDirections& above, const FourierDirections& below, int modes,
                                   const InterfaceProjectionSettings& settings) {
  // Only a plain function is known by its address; anything else is projected every time.
  const EvalFunction* function = eval.target<EvalFunction>();
  if (!function) return project(alpha, n_above, n_below, eval, above, below, modes, settings);
  CacheKey key{alpha, n_above, n_below, modes, settings.cell_points, settings.input_points, settings.phi_panels,
               settings.phi_points, *function, above.mu, above.x_lo, above.x_hi, below.mu, below.x_lo, below.x_hi};
  {
    std::lock_guard<std::mutex> lock(cache_mutex);
    for (auto it = cache.begin(); it != cache.end(); ++it)
      if (it->first == key) {
        cache.splice(cache.begin(), cache, it);
        return *cache.front().second;
      }
  }
  auto made = std::make_shared<const InterfaceFourier>(project(alpha, n_above, n_below, eval, above, below, modes, settings));
  std::lock_guard<std::mutex> lock(cache_mutex);
  cache.emplace_front(std::move(key), made);
  if (cache.size() > kCacheSize) cache.pop_back();
  return *made;
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

}  // namespace lamina
