#include "materials/random_walk.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "materials/dwivedi.h"
#include "materials/fresnel.h"
#include "materials/henyey_greenstein.h"
#include "materials/microfacet.h"
#include "materials/zeroth_order.h"

namespace lamina {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// ---------------------------------------------------------------------------------------------
// Spectral MIS (one walk for three channels).
//
// The RGB coefficients differ per channel, but a walk samples one set of distances and
// directions. We use one-sample multiple importance sampling over the channels with the balance
// heuristic (Veach 1997 section 9.2.4; the hero-wavelength scheme of Wilkie et al. 2014 and
// pbrt-v4 section 14.2.2): the walk picks a channel h uniformly ONCE and samples everything in
// h's coefficients; the density of the sampled path is then the mixture (1/3) sum_k p_k(path)
// over the channels' path densities, and the weight of channel c is
//     W_c = f_c(path) / ((1/3) sum_k p_k(path)) = a_c * 3 / sum_k (p_k / p_c),
// where a_c = f_c / p_c is what a scalar walk in channel c would carry (products of albedos and
// substrate albedos: <= 1). So W_c <= 3 a_c: weights stay bounded. (The per-decision mixture --
// a new channel for every flight and every phase sample, the first design -- multiplies a ratio
// of up to 3 per collision and its variance explodes for strongly coloured media; the test
// SpectralWalkMatchesGreyWalks caught it.) Every prefix of the path is sampled with the same
// mixture, so an event's throughput is W_c of the prefix.
// The ratios p_k/p_h are kept as logarithms (lr_k) to survive long walks. Per decision:
//  * free flight: an optical depth tau ~ Exp(1) is drawn in h; the flight is traced with h's
//    coefficients, CARRYING the rest of tau across interfaces so that a flight through several
//    layers is exact. A flight of straight pieces s_j in layers j (joined by Fresnel
//    reflections/refractions, whose probabilities do not depend on the channel and cancel) has
//    in channel k the density
//        collision in layer l:  sigma_t,k(l) exp(-T_k),   T_k = sum_j sigma_t,k(j) s_j,
//        reaching an exit / the substrate uncollided:  exp(-T_k);
//    the kernel of channel c is sigma_s,c(l) exp(-T_c) (collision and scattering) or exp(-T_c):
//    a_c *= sigma_s,c/sigma_t,c (the albedo), lr_k += log(p_k/p_h) of the flight.
//    The absorbed part (sigma_a,c instead of sigma_s,c) is tallied as a direct estimate.
//  * phase function: in h, a lobe is chosen by its share of h's scattering, then HG with that
//    lobe's g: density p_h(cos) (the layer's phase mixture in h); a channel that does not
//    scatter in this layer samples isotropically (1/(4 pi)) as its technique. a_c *= 1,
//    lr_k += log(q_k / q_h).
//  * Lambert substrate: cosine sampling in every channel: a_c *= albedo_c.
// For a grey stack every lr_k is exactly 0 and W = a: the scalar walk, bit for bit.
// ---------------------------------------------------------------------------------------------

// Phase function identical in all channels, so that the phase sampling ratios are 1 and need
// not be computed. The lobes' shares of the scattering must agree across channels; to 1e-12
// relative, not exactly: a composite layer's shares are products and sums of its components'
// fractions and coefficients, which round differently per channel even when the components
// scatter in the same proportions (skin: the same sigma_s in every component), and an exact test
// would send such layers down the coloured path, six HG evaluations per connection instead of one,
// for a ratio that differs from 1 by 1e-16.
bool phase_is_grey(const Layer& layer) {
  const Spectrum total = layer.sigma_s();
  for (int c = 0; c < kChannels; ++c)
    if (!(total[c] > 0.0)) return false;
  for (const PhaseLobe& lobe : layer.lobes) {
    if (!lobe.g.is_grey()) return false;
    for (int c = 1; c < kChannels; ++c) {
      const double a = lobe.sigma_s[c] * total[0], b = lobe.sigma_s[0] * total[c];
      if (std::abs(a - b) > 1e-12 * std::max(std::abs(a), std::abs(b))) return false;
    }
  }
  return true;
}

// All lobes share one g in every channel: the phase function is the single HG lobe of *g.
bool single_henyey_greenstein(const Layer& layer, double* g) {
  if (layer.lobes.empty()) return false;
  *g = layer.lobes[0].g[0];
  for (const PhaseLobe& lobe : layer.lobes)
    for (int c = 0; c < kChannels; ++c)
      if (lobe.g[c] != *g) return false;
  return true;
}

// Dwivedi's v0 of each channel of a layer (0: no guiding there), from its reduced single-
// scattering albedo sigma_s (1 - g) / (sigma_s (1 - g) + sigma_a), g the scattering-weighted mean
// of its lobes (the similarity relation: the zero-variance theory is for isotropic scattering).
Spectrum layer_dwivedi_v0(const Layer& layer) {
  Spectrum v0;
  for (int c = 0; c < kChannels; ++c) {
    double s = 0.0, sg = 0.0;
    for (const PhaseLobe& lobe : layer.lobes) {
      s += lobe.sigma_s[c];
      sg += lobe.sigma_s[c] * lobe.g[c];
    }
    const double reduced = s - sg;  // sigma_s (1 - mean g)
    v0[c] = reduced > 0.0 ? dwivedi_v0(reduced / (reduced + layer.sigma_a[c])) : 0.0;
  }
  return v0;
}

// Guided walks apply only to flights from layers that scatter isotropically (every lobe g = 0,
// e.g. after the similarity transform). Dwivedi's density is the zero-variance direction for
// isotropic scattering; against a forward-peaked phase function the mixture's weights,
// phase / (mixture), vary so much that their products over a long walk are heavy-tailed (an
// exact skin stack, g = 0.6-0.8: the reflectance of 2e4 guided walks came out 20-40 % low,
// docs/random_walk.md, "Guided walks").
bool scatters_isotropically(const Layer& layer) {
  for (const PhaseLobe& lobe : layer.lobes)
    for (int c = 0; c < kChannels; ++c)
      if (lobe.g[c] != 0.0) return false;
  return !layer.lobes.empty();
}

// The probability of the guided technique for flights from this layer.
double layer_guiding(const Layer& layer, double guiding) {
  return guiding > 0.0 && scatters_isotropically(layer) ? guiding : 0.0;
}

// The guided technique's extinction for a flight along direction cosine mu (with +z, towards the
// top): sigma_t (1 - mu / v0), or sigma_t where the channel is not guided.
double guided_sigma(double sigma_t, double v0, double mu) { return v0 > 0.0 ? sigma_t * (1.0 - mu / v0) : sigma_t; }
// Its direction density per steradian: Dwivedi's, or isotropic where the channel is not guided.
double guided_direction_pdf(double v0, double mu) { return v0 > 0.0 ? dwivedi_pdf(v0, mu) : kInv4Pi; }

// The sampling density of a new direction for the technique of channel k (see above).
double phase_sampling_pdf(const Layer& layer, int k, double cos_theta) {
  return layer.sigma_s()[k] > 0.0 ? layer.phase(k, cos_theta) : kInv4Pi;
}

struct PathWeight {
  Spectrum a{1.0};    // f_c / p_c: the scalar walk's weight in channel c
  Spectrum lr{0.0};   // log(p_k / p_h): the channels' path densities relative to the hero's
  double scale = 1.0; // entry transmission and Russian roulette factors (common to all channels)

  Spectrum value() const {
    Spectrum w;
    values(a, &w, nullptr, nullptr);
    return w;
  }
  // value() of this path and of the same path with the scalar weights `other` (the collision's
  // absorbed part: the same densities), sharing the exponentials.
  void values(const Spectrum& a_first, Spectrum* first, const Spectrum* a_second, Spectrum* second) const {
    // Grey path (all densities equal): sum_k p_k/p_c = 3 exactly, W = a.
    if (lr[0] == 0.0 && lr[1] == 0.0 && lr[2] == 0.0) {
      *first = a_first * scale;
      if (second) *second = *a_second * scale;
      return;
    }
    // kChannels / sum_k exp(lr_k - lr_c) = kChannels e_c / sum_k e_k with e_k = exp(lr_k - max lr):
    // three exponentials instead of nine, and none overflows (the largest is 1).
    const double top = std::max(lr[0], std::max(lr[1], lr[2]));
    Spectrum e;
    // The largest is exp(0) = 1 exactly: no call for it. (top >= lr of the hero = 0, and no lr is
    // +inf: the hero's density is positive on the paths it samples.)
    for (int k = 0; k < kChannels; ++k) e[k] = lr[k] == top ? 1.0 : std::exp(lr[k] - top);
    const double factor = scale * kChannels / (e[0] + e[1] + e[2]);  // one division, not one per channel
    auto weigh = [&](const Spectrum& weights, Spectrum* w) {
      *w = Spectrum(0.0);
      for (int c = 0; c < kChannels; ++c)
        if (weights[c] != 0.0 && e[c] > 0.0) (*w)[c] = weights[c] * e[c] * factor;  // else c cannot produce this path
    };
    weigh(a_first, first);
    if (second) weigh(*a_second, second);
  }
};

// tau += sigma_t * length per channel, with 0 * inf = 0 (a clear channel over an infinite path).
void add_optical_depth(Spectrum* tau, const Spectrum& sigma_t, double length) {
  if (length <= 0.0) return;
  for (int c = 0; c < kChannels; ++c)
    if (sigma_t[c] > 0.0) (*tau)[c] += sigma_t[c] * length;
}

// lr_k += log(p_k / p_h) for a flight that left uncollided with optical depths tau.
void flight_escaped(PathWeight* pw, const Spectrum& tau, int hero) {
  for (int k = 0; k < kChannels; ++k)
    if (k != hero) pw->lr[k] -= tau[k] - tau[hero];
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// The path from a point inside the stack straight out to an outside direction w.
//
// Snell's law in a plane-parallel stack conserves n sin(theta), so the direction inside every
// layer j is fixed by w: sin_j = (n_out / n_j) sin_out, mu_j = sqrt(1 - sin_j^2) (if sin_j >= 1
// no propagating direction refracts out to w: the path does not exist). Going up from layer l the
// path crosses the top interfaces of layers l, l-1, ..., 0 and the full thickness of layers
// l-1 ... 0; going down, the bottom interfaces of layers l ... N-1 and the layers below l. So
// the per-layer terms accumulate from the outside inwards.
// ---------------------------------------------------------------------------------------------
RoughDielectric top_interface(const LayerStack& stack) {
  return RoughDielectric{{stack.top_roughness}, stack.above_ior, stack.layers[0].ior};
}

namespace {

// Through a rough top: layer 0's inside direction, the transmission's radiance estimate and the
// MIS density ratio for the outside direction w (w.z > 0) and the direction t in layer 0
// pointing away from the surface (t.z < 0; -t is the propagation direction towards the top).
// See prepare_exit in random_walk.h.
struct RoughCrossing {
  bool exists = false;
  glm::dvec3 inside{0.0};
  double radiance_scale = 0.0;  // f_t(w, t) |t.z| / p(t | w)
  double jacobian = 0.0;        // pdf_walk(w | t) / p(t | w)
};
RoughCrossing cross_rough_top(const RoughDielectric& top, const glm::dvec3& w, const glm::dvec3& t) {
  RoughCrossing c;
  if (!(t.z < 0.0) || !(w.z > 0.0)) return c;
  const double p_t = top.refraction_pdf(w, t);  // the connection's sampling density of t
  if (!(p_t > 0.0)) return c;
  c.radiance_scale = top.eval(w, t) * -t.z / p_t;
  c.jacobian = top.pdf(t, w) / p_t;  // the walk meets the facets from t: visible normals of t
  c.inside = -t;
  c.exists = c.radiance_scale > 0.0;
  return c;
}

void prepare_exit_impl(const LayerStack& stack, const glm::dvec3& w, ExitDirection* out, double guiding,
                       const RoughCrossing* rough) {
  out->w = w;
  out->layers.clear();
  out->guided.clear();
  if (!(w.z != 0.0)) return;
  const bool up = w.z > 0.0;
  if (!up && !stack.transmits()) return;
  const int n_layers = static_cast<int>(stack.layers.size());
  const double n_out = up ? stack.above_ior : stack.below.ior;
  const double mu_out = std::min(1.0, std::abs(w.z));
  out->up = up;
  out->mu_out = mu_out;
  // Snell's invariant is taken from a reference direction: w outside for smooth interfaces; the
  // sampled direction in layer 0 behind a rough top (which it has already crossed: its
  // transmission and density ratio start the products).
  const bool through_rough = up && rough != nullptr;
  if (through_rough && !rough->exists) return;
  const double n_ref = through_rough ? stack.layers[0].ior : n_out;
  const double tx = through_rough ? rough->inside.x : w.x, ty = through_rough ? rough->inside.y : w.y;
  const double mu_ref = through_rough ? rough->inside.z : mu_out;
  const double sin2_ref = std::max(0.0, (1.0 - mu_ref) * (1.0 + mu_ref));
  const double top_scale = through_rough ? rough->radiance_scale : 1.0;
  const double top_jacobian = through_rough ? rough->jacobian : 1.0;
  out->layers.resize(n_layers);
  if (guiding > 0.0) out->guided.resize(n_layers);
  bool reachable = true;  // every layer between this one and the outside propagates towards w
  double fresnel_t = 1.0;
  Spectrum tau_beyond, guided_tau_beyond;
  for (int step = 0; step < n_layers; ++step) {
    const int l = up ? step : n_layers - 1 - step;
    const Layer& layer = stack.layers[l];
    ExitDirection::LayerExit& e = out->layers[l];
    const double r = n_ref / layer.ior;
    const double sin2 = r * r * sin2_ref;
    const double mu = through_rough && l == 0 ? mu_ref : sin2 < 1.0 ? std::sqrt(1.0 - sin2) : -1.0;
    reachable = reachable && mu > 0.0;
    if (!reachable) continue;  // e.exists stays false, and for every layer further in
    if (!(through_rough && l == 0)) {
      const double n_next = up ? stack.ior_above_interface(l) : stack.ior_below_interface(l + 1);
      fresnel_t *= 1.0 - fresnel_dielectric(mu, layer.ior, n_next);
    }
    e.exists = true;
    e.inside = {tx * r, ty * r, up ? mu : -mu};
    e.mu_inside = mu;
    e.fresnel_t = fresnel_t;
    e.radiance_scale = fresnel_t * r * r * top_scale;
    e.jacobian = top_jacobian * r * r * mu_ref / mu;
    e.grey_phase = phase_is_grey(layer);
    e.single_lobe = e.grey_phase && single_henyey_greenstein(layer, &e.single_g);
    e.sigma_s = layer.sigma_s();
    e.sigma_t = layer.sigma_a + e.sigma_s;
    const Spectrum& sigma_t = e.sigma_t;
    for (int c = 0; c < kChannels; ++c) e.depth_rate[c] = sigma_t[c] > 0.0 ? sigma_t[c] / mu : 0.0;
    e.tau_beyond = tau_beyond;
    if (guiding > 0.0) {
      ExitDirection::GuidedExit& g = out->guided[l];
      g.guiding = layer_guiding(layer, guiding);
      const Spectrum v0 = g.guiding > 0.0 ? layer_dwivedi_v0(layer) : Spectrum(0.0);
      const double mu_dir = up ? mu : -mu;  // the inside direction's cosine with +z
      for (int c = 0; c < kChannels; ++c) {
        const double rate = guided_sigma(sigma_t[c], v0[c], mu_dir);
        g.depth_rate[c] = rate > 0.0 ? rate / mu : 0.0;
        g.direction_pdf[c] = guided_direction_pdf(v0[c], mu_dir);
      }
      g.tau_beyond = guided_tau_beyond;
      add_optical_depth(&guided_tau_beyond, g.depth_rate * mu, layer.thickness / mu);
    }
    e.min_depth_rate = std::min(e.depth_rate[0], std::min(e.depth_rate[1], e.depth_rate[2]));
    e.min_tau_beyond = std::min(tau_beyond[0], std::min(tau_beyond[1], tau_beyond[2]));
    add_optical_depth(&tau_beyond, sigma_t, layer.thickness / mu);  // for the layers further in
  }
}

}  // namespace

void prepare_exit(const LayerStack& stack, const glm::dvec3& w, ExitDirection* out, double guiding,
                  glm::dvec2 u_interface) {
  if (!stack.rough_top() || !(w.z > 0.0)) {
    prepare_exit_impl(stack, w, out, guiding, nullptr);
    return;
  }
  // Sample the inside direction: visible normals from w, refraction into layer 0.
  const RoughDielectric top = top_interface(stack);
  glm::dvec3 t;
  double fresnel, masking;
  RoughCrossing crossing;
  if (top.sample_refraction(w, u_interface, &t, &fresnel, &masking)) crossing = cross_rough_top(top, w, t);
  prepare_exit_impl(stack, w, out, guiding, &crossing);
}

void prepare_exit_through(const LayerStack& stack, const glm::dvec3& w, const glm::dvec3& inside_up,
                          ExitDirection* out, double guiding) {
  if (!stack.rough_top() || !(w.z > 0.0)) {
    prepare_exit_impl(stack, w, out, guiding, nullptr);
    return;
  }
  const RoughCrossing crossing = cross_rough_top(top_interface(stack), w, -inside_up);
  prepare_exit_impl(stack, w, out, guiding, &crossing);
}

ExitDirection prepare_exit(const LayerStack& stack, const glm::dvec3& w, double guiding) {
  ExitDirection exit;
  prepare_exit(stack, w, &exit, guiding);
  return exit;
}

double exit_optical_depth_bound(const LayerStack& stack, const ScatterEvent& event, const ExitDirection& exit) {
  if (exit.layers.empty() || !exit.layers[event.layer].exists) return kInf;
  const ExitDirection::LayerExit& path = exit.layers[event.layer];
  const double distance = exit.up ? event.depth : stack.layers[event.layer].thickness - event.depth;
  return path.min_tau_beyond + (path.min_depth_rate > 0.0 ? path.min_depth_rate * distance : 0.0);
}

DirectExit connect_direct(const LayerStack& stack, const ScatterEvent& event, const ExitDirection& exit) {
  DirectExit out;
  if (exit.layers.empty()) return out;
  const ExitDirection::LayerExit& path = exit.layers[event.layer];
  if (!path.exists) return out;
  const Layer& layer = stack.layers[event.layer];
  // Emission towards the inside direction per unit path (p / mu, or albedo / pi at the
  // substrate; see the derivation below) and the walk's sampling density of that direction in
  // the inside solid angle, per channel as the hero's technique.
  Spectrum emission, sampling;
  if (event.kind == ScatterEvent::Kind::Substrate) {
    if (stack.below.kind != Below::Kind::Lambert || !exit.up) return out;
    emission = stack.below.albedo * kInvPi;
    sampling = Spectrum(path.mu_inside * kInvPi);  // cosine sampling
  } else {
    const double cos_theta = glm::dot(event.direction, path.inside);
    if (path.grey_phase) {
      const double p = path.single_lobe ? henyey_greenstein(cos_theta, path.single_g) : layer.phase(0, cos_theta);
      emission = Spectrum(p / path.mu_inside);
      sampling = Spectrum(p);
      if (path.single_lobe) out.phase = p;
    } else {
      const Spectrum& sigma_s = path.sigma_s;
      for (int c = 0; c < kChannels; ++c) {
        const double p = layer.phase(c, cos_theta);
        emission[c] = p / path.mu_inside;
        sampling[c] = sigma_s[c] > 0.0 ? p : kInv4Pi;  // phase_sampling_pdf
      }
    }
  }
  const double distance = exit.up ? event.depth : layer.thickness - event.depth;
  // A volume event's next flight is guided with probability q (WalkSettings::guiding): its
  // density is the mixture of the two techniques' direction densities times their escape
  // probabilities.
  const double q = event.kind == ScatterEvent::Kind::Volume && !exit.guided.empty() ? exit.guided[event.layer].guiding : 0.0;
  double pdf_sum = 0.0, pdf[kChannels];
  for (int c = 0; c < kChannels; ++c) {
    const double tau = path.tau_beyond[c] + (path.depth_rate[c] > 0.0 ? path.depth_rate[c] * distance : 0.0);
    const double transmittance = std::exp(-tau);
    out.weight[c] = emission[c] * transmittance * path.radiance_scale;
    // The walk flies in its hero channel: no collision on the way out with probability
    // exp(-tau_hero), each Fresnel transmission taken with probability (1 - R).
    double technique = sampling[c] * transmittance;
    if (q > 0.0) {
      const ExitDirection::GuidedExit& g = exit.guided[event.layer];
      const double tau_g = g.tau_beyond[c] + (g.depth_rate[c] > 0.0 ? g.depth_rate[c] * distance : 0.0);
      technique = (1.0 - q) * technique + q * g.direction_pdf[c] * std::exp(-tau_g);
    }
    pdf[c] = technique * path.jacobian * path.fresnel_t;
    pdf_sum += pdf[c];
  }
  // Indexed, not tested per channel: the hero is random, and `c == hero` was mispredicted.
  out.pdf_hero = pdf[event.hero];
  out.pdf_for_mis = pdf_sum / kChannels;
  return out;
}

// ---------------------------------------------------------------------------------------------
// connection_weight: derivation.
//
// Let the incident beam deliver irradiance E (power per unit area of the surface plane). The
// model is position free, so we may think of N photons spread over an area A, each carrying
// power E A / N times its weight. A volume event with throughput W (scattered power, albedo
// applied) re-emits the power (E A / N) W with angular density p(d -> d') per steradian (HG
// mixture of the layer in that channel). Smeared over the area, the events in a slab dz form the
// volume emission  eps(d') = (E / (N dz)) sum_e W_e p(d_e -> d')  [W / (m^3 sr)], the source
// term of the transfer equation dL/ds = -sigma_t L + eps (Hanrahan and Krueger eq. 4). Along d'
// the slab has path length dz / |mu'|, so it adds the radiance eps dz / |mu'|, which then
//  * is attenuated by exp(-sum_j tau_j / |mu_j|) through the rest of its layer and the layers
//    between it and the outside (Beer-Lambert along the refracted path, mu_j from Snell),
//  * keeps the fraction (1 - R_k) at every interface it crosses (Fresnel transmission),
//  * is multiplied by (n_{k+1}/n_k)^2 at each crossing (the n^2 law of radiance; Veach's thesis
//    section 5.2; the slides' T^{12} = (n_t/n_i)^2 (1 - R)): the product telescopes to
//    (n_out / n_layer)^2.
// The BRDF/BTDF is f = L_o / E, so each event contributes
//    f(wi -> w) += (1/N) W_e * p(d_e -> d') / |mu'| * exp(-sum tau_j/|mu_j|) * prod(1 - R_k)
//                  * (n_out / n_layer)^2,
// i.e. connection_weight = p(d_e -> d') / |mu'| * exp(-sum tau_j/|mu_j|) * prod(1 - R_k)
//                          * (n_out / n_layer)^2,
// and throughput = W_e (the 1/N is the caller's average over walks).
// Substrate events: a Lambert surface of albedo a under the irradiance (E/N) sum W_e reflects the
// radiance (a / pi) (E/N) sum W_e into every inside upward direction, so p/|mu'| is replaced by
// a/pi (throughput = W_e arriving, before the albedo).
// Check: the walk leaves straight from a grey event along w with exit weight W_e (the sampling
// ratios are 1) and density connection_pdf(w); a power W per solid angle dw gives the radiance
// W / (|mu_out| dw) per unit irradiance, so the exits estimate W_e connection_pdf / |mu_out|
// = W_e p (n_out/n_l)^2 / |mu'| exp(-tau) prod(1-R): the same (tests/materials/test_random_walk).
// ---------------------------------------------------------------------------------------------
Spectrum connection_weight(const LayerStack& stack, const ScatterEvent& event, const glm::dvec3& w) {
  return connect_direct(stack, event, prepare_exit(stack, w)).weight;
}

// connection_weight_all_paths: with the notation of the derivation above, let the event sit in
// layer k (thickness h, index n_k) at depth z, and let mu be the cosine in layer k of the
// direction that refracts out to w (Snell). Inside layer k there are two such directions,
// d_up = (w_t n_out/n_k, +mu) and d_dn = (w_t n_out/n_k, -mu), and the event emits into both:
// S_up = p(d -> d_up)/mu and S_dn = p(d -> d_dn)/mu (the substrate: S_up = albedo/pi, S_dn = 0).
// With A = exp(-sigma_t z/mu) (to the top of layer k), B = exp(-sigma_t (h - z)/mu) (to its
// bottom), t = exp(-sigma_t h/mu) (one full pass), and the adding-method elements of
// zeroth_order.h for everything above layer k (transmittance T_a out of the top, reflectance
// R_a back down) and below it (T_b, R_b), the unscattered radiance bounces between the two
// parts as a geometric series with ratio R_a R_b t^2, so (each path leaves the stack through the
// same media sequence, so the n^2 law gives the same (n_out/n_k)^2 for all of them):
//   f_up(w) += W (n_out/n_k)^2 T_a (S_up A + S_dn B R_b t) / (1 - R_a R_b t^2),
//   f_dn(w) += W (n_out/n_k)^2 T_b (S_dn B + S_up A R_a t) / (1 - R_a R_b t^2).
// (Hanrahan and Krueger's first-order formulas are the case of one layer and one event.)
ConnectionTarget prepare_connection(const LayerStack& stack, const glm::dvec3& w) {
  ConnectionTarget target;
  target.w = w;
  if (!(w.z != 0.0)) return target;
  const bool up = w.z > 0.0;
  if (!up && !stack.transmits()) return target;
  target.valid = true;
  target.mu_out = std::min(1.0, std::abs(w.z));
  const std::size_t n = stack.layers.size();
  for (int c = 0; c < kChannels; ++c) {
    const StackTransport st = unscattered_transport(stack, c, target.mu_out, up ? Outside::Above : Outside::Below);
    target.mu.resize(n);
    target.t[c].resize(n);
    target.t_out[c].resize(n);
    target.r_above[c].resize(n);
    target.r_below[c].resize(n);
    for (std::size_t k = 0; k < n; ++k) {
      const LayerTransport& L = st.layers[k];
      target.mu[k] = L.mu;
      target.t[c][k] = L.t;
      target.t_out[c][k] = up ? L.above.T : L.below.T;
      target.r_above[c][k] = L.above.R_bottom;
      target.r_below[c][k] = L.below.R_top;
    }
  }
  return target;
}

Spectrum connection_weight_all_paths(const LayerStack& stack, const ScatterEvent& event,
                                     const glm::dvec3& w) {
  return connection_weight_all_paths(stack, event, prepare_connection(stack, w));
}

Spectrum connection_weight_all_paths(const LayerStack& stack, const ScatterEvent& event,
                                     const ConnectionTarget& target) {
  if (!target.valid) return Spectrum(0.0);
  const glm::dvec3& w = target.w;
  const bool up = w.z > 0.0;
  const bool substrate = event.kind == ScatterEvent::Kind::Substrate;
  if (substrate && (!up || stack.below.kind != Below::Kind::Lambert)) return Spectrum(0.0);
  const int k = event.layer;
  const Layer& layer = stack.layers[k];
  const double mu = target.mu[k];
  if (!(mu > 0.0)) return Spectrum(0.0);
  const double n_out = up ? stack.above_ior : stack.below.ior;
  const double r = n_out / layer.ior;
  const glm::dvec3 d_up{w.x * r, w.y * r, mu}, d_dn{w.x * r, w.y * r, -mu};
  const double cos_up = glm::dot(event.direction, d_up), cos_dn = glm::dot(event.direction, d_dn);
  const Spectrum sigma_t = layer.sigma_t();
  Spectrum value;
  for (int c = 0; c < kChannels; ++c) {
    const double T_out = target.t_out[c][k];
    if (T_out == 0.0) continue;
    auto attenuation = [&](double distance) {
      if (distance <= 0.0 || sigma_t[c] == 0.0) return 1.0;
      return std::exp(-sigma_t[c] * distance / mu);
    };
    double s_up, s_dn;
    if (substrate) {
      s_up = stack.below.albedo[c] * kInvPi;
      s_dn = 0.0;
    } else {
      s_up = layer.phase(c, cos_up) / mu;
      s_dn = layer.phase(c, cos_dn) / mu;
    }
    const double a = attenuation(event.depth);
    const double b = layer.semi_infinite() ? 0.0 : attenuation(layer.thickness - event.depth);
    const double t = target.t[c][k], ra = target.r_above[c][k], rb = target.r_below[c][k];
    const double cycle = 1.0 - ra * rb * t * t;
    if (!(cycle > 0.0)) continue;
    const double inner = up ? s_up * a + s_dn * b * rb * t : s_dn * b + s_up * a * ra * t;
    value[c] = r * r * T_out * inner / cycle;
  }
  return value;
}

double connection_pdf(const LayerStack& stack, const ScatterEvent& event, const glm::dvec3& w, double guiding) {
  // Jacobian of the refraction: n_l^2 mu' d(omega') = n_out^2 mu_out d(omega) (from
  // n_l sin' = n_out sin and n_l cos' dtheta' = n_out cos dtheta), so
  // d(omega')/d(omega) = (n_out/n_l)^2 mu_out / mu' (ExitDirection::LayerExit::jacobian).
  return connect_direct(stack, event, prepare_exit(stack, w, guiding)).pdf_hero;
}

void prepare_walk(const LayerStack& stack, const WalkSettings& settings, WalkPlan* plan) {
  plan->stack = &stack;
  plan->settings = settings;
  const int n_layers = static_cast<int>(stack.layers.size());
  plan->may_switch = settings.similarity_after >= 0 && settings.similar != nullptr &&
                     settings.similar->layers.size() == stack.layers.size();
  plan->rough = stack.rough_top();
  plan->top = plan->rough ? top_interface(stack) : RoughDielectric{};
  // [0, n_layers): the stack; [n_layers, 2 n_layers): the similar stack, if any.
  plan->layers.resize(plan->may_switch ? 2 * n_layers : n_layers);
  for (int k = 0; k < static_cast<int>(plan->layers.size()); ++k) {
    const Layer& layer = k < n_layers ? stack.layers[k] : settings.similar->layers[k - n_layers];
    WalkPlan::LayerCache& c = plan->layers[k];
    c.sigma_t = layer.sigma_t();
    c.sigma_s = layer.sigma_s();
    for (int ch = 0; ch < kChannels; ++ch) {
      const bool extinct = c.sigma_t[ch] > 0.0;
      // A grey layer (every channel's sigma_t the same, as in most measured slabs) takes one
      // logarithm, not three.
      c.log_sigma_t[ch] = !extinct ? -kInf
                          : ch > 0 && c.sigma_t[ch] == c.sigma_t[ch - 1] ? c.log_sigma_t[ch - 1]
                                                                         : std::log(c.sigma_t[ch]);
      c.albedo[ch] = extinct ? c.sigma_s[ch] / c.sigma_t[ch] : 0.0;
      c.absorbed_share[ch] = extinct ? layer.sigma_a[ch] / c.sigma_t[ch] : 0.0;
    }
    c.grey_phase = phase_is_grey(layer);
    for (int ch = 0; ch < kChannels; ++ch) {
      c.g[ch] = layer.lobes.empty() ? 0.0 : layer.lobes[0].g[ch];
      c.one_g[ch] = !layer.lobes.empty();
      for (const PhaseLobe& lobe : layer.lobes) c.one_g[ch] = c.one_g[ch] && lobe.g[ch] == c.g[ch];
    }
    c.guiding = layer_guiding(layer, settings.guiding);
    c.v0 = c.guiding > 0.0 ? layer_dwivedi_v0(layer) : Spectrum(0.0);
  }
  // A grey stack (every channel's coefficients equal, LayerStack::grey) samples the same densities
  // in every channel: the channels' optical depths are equal, every lr_k stays exactly 0 and the
  // weight is the scalar walk's. Such a walk skips the per-channel optical depths and density
  // ratios (the same numbers, bit for bit: `lamina brdf`'s measured slabs are grey).
  plan->spectral = !stack.grey() || (plan->may_switch && !settings.similar->grey()) || settings.guiding > 0.0;
}

WalkResult random_walk(const LayerStack& stack, const glm::dvec3& wi, Rng& rng,
                       const EventCallback& on_event, const WalkSettings& settings, int chosen_hero) {
  thread_local WalkPlan plan;
  prepare_walk(stack, settings, &plan);
  return random_walk(plan, wi, rng, on_event, chosen_hero);
}

WalkResult random_walk(const WalkPlan& plan, const glm::dvec3& wi, Rng& rng, const EventCallback& on_event,
                       int chosen_hero) {
  const LayerStack& stack = *plan.stack;
  const WalkSettings& settings = plan.settings;
  WalkResult result;
  const int n_layers = static_cast<int>(stack.layers.size());
  const bool rough = plan.rough;
  const RoughDielectric& top = plan.top;
  const bool may_switch = plan.may_switch;
  const bool spectral = plan.spectral;

  // Entry: the light arrives along -wi; the walk carries the refracted part (1 - R).
  const double n_top = stack.layers[0].ior;
  PathWeight pw;
  glm::dvec3 d = -wi;
  if (rough) {
    // Through a rough top the packet meets a facet m ~ D_wi (the visible normals) and carries
    // the power refracted there, (1 - F(wi.m)) G2/G1(wi) (Walter eq. 21 sampled as in
    // RoughDielectric::sample, power mode; the reflected part F is the caller's glossy lobe). A
    // refraction that points back up, or none at all, is the model's single-scattering loss.
    const double u0 = rng.uniform(), u1 = rng.uniform();
    glm::dvec3 t;
    double f, g;
    if (!top.sample_refraction(wi, {u0, u1}, &t, &f, &g)) {
      result.interface_loss = Spectrum(1.0 - f);
      result.end = WalkResult::End::Absorbed;
      return result;
    }
    pw.scale = (1.0 - f) * g;
    result.interface_loss = Spectrum((1.0 - f) * (1.0 - g));
    d = t;
  } else {
    const double r_entry = fresnel_dielectric(wi.z, stack.above_ior, n_top);
    pw.scale = 1.0 - r_entry;
    if (!(r_entry < 1.0) || !refract_through_plane(&d, stack.above_ior, n_top)) {
      result.end = WalkResult::End::Absorbed;  // nothing enters (grazing or TIR from a denser above)
      return result;
    }
  }
  const double entry_weight = pw.scale;
  const WalkPlan::LayerCache* cache = plan.layers.data();  // switches to the similar half
  const std::vector<Layer>* layers = &stack.layers;
  bool similar = false;

  // The hero channel: every decision of this walk is sampled in its coefficients. Uniform (the
  // one-sample MIS weights of PathWeight assume probability 1/3 per channel), or the caller's
  // (random_walk.h: it must be uniform marginally). The uniform is drawn in both cases so that the
  // walk's later random numbers do not depend on who chose.
  const double u_hero = rng.uniform();
  const int hero = chosen_hero >= 0 && chosen_hero < kChannels
                       ? chosen_hero
                       : std::min(kChannels - 1, static_cast<int>(u_hero * kChannels));

  int l = 0;          // current layer
  double z = 0.0;     // depth below the top of layer l, mm
  ScatterEvent last_event;
  bool reflected_since_event = false;
  int interactions_at_event = -1;  // result.interactions when the last volume event was emitted
  bool last_flight_guided = false;  // the current flight's direction came from a guided mixture
  Spectrum weight = pw.value();

  // Russian roulette (unbiased: survivors divide by the survival probability). Returns false if
  // the walk dies.
  auto roulette = [&](bool at_scatter) {
    double q = 1.0;
    // Relative to the entering weight 1 - R: at grazing incidence that is tiny, and an absolute
    // threshold would kill almost every walk at once (large relative variance for no gain).
    if (at_scatter && weight.max() < settings.roulette_threshold * entry_weight)
      q = settings.roulette_survival;
    const int t = result.interactions;
    if (t > settings.forced_exponential_after && result.cut_weight.is_black()) result.cut_weight = weight;
    if (t > settings.forced_exponential_after) {
      q *= settings.forced_survival;
    } else if (t > settings.forced_after) {
      q *= std::sqrt((t - 1.0) / t);  // cumulative survival sqrt(forced_after / t), see WalkSettings
    }
    if (q >= 1.0) return true;
    if (rng.uniform() >= q) {
      result.end = WalkResult::End::Roulette;
      return false;
    }
    pw.scale /= q;
    weight /= q;
    return true;
  };
  // The similarity option: after the similarity_after-th event has sampled its new direction,
  // everything that follows happens in the similar stack.
  auto switch_if_due = [&] {
    if (may_switch && !similar && result.scatter_count >= settings.similarity_after) {
      similar = true;
      cache = plan.layers.data() + n_layers;
      layers = &settings.similar->layers;
    }
  };
  // Fills in the exit; the caller then returns `result` itself (named, so that it is built in
  // the caller's return slot: a lambda returning a copy of it copied the whole result per walk).
  auto finish_exit = [&](WalkResult::Side side, const glm::dvec3& out) {
    result.side = side;
    result.end = side == WalkResult::Side::Top ? WalkResult::End::ExitTop : WalkResult::End::ExitBottom;
    result.direction = out;
    result.weight = pw.value();
    if (result.scatter_count > 0 && !reflected_since_event) {
      result.straight_from_last_event = true;
      if (!settings.compute_exit_pdf) return;
      const LayerStack& last_stack = last_event.similar ? *settings.similar : stack;
      if (rough && side == WalkResult::Side::Top) {
        ExitDirection exit;
        prepare_exit_through(last_stack, out, result.top_inside, &exit, settings.guiding);
        result.exit_pdf = connect_direct(last_stack, last_event, exit).pdf_hero;
      } else {
        result.exit_pdf = connection_pdf(last_stack, last_event, out, settings.guiding);
      }
    }
  };
  // Nobody reads the events of a walk with no callback that computes no exit pdf (`lamina brdf`).
  const bool keep_events = static_cast<bool>(on_event) || settings.compute_exit_pdf;
  auto emit = [&](ScatterEvent::Kind kind, const Spectrum& throughput) {
    reflected_since_event = false;
    if (!keep_events) return;
    // Volume events count one interaction each (the collision); any more since the previous
    // volume event were interfaces. A guided flight has another direction density.
    const bool from_previous = kind == ScatterEvent::Kind::Volume && interactions_at_event >= 0 &&
                               result.interactions == interactions_at_event + 1 &&
                               last_event.layer == l && last_event.similar == similar && !last_flight_guided;
    // Built in place (every field is set): a copy of an event just stored field by field was a
    // visible share of an event's time.
    ScatterEvent& event = last_event;
    event.kind = kind;
    event.order = result.scatter_count;
    event.layer = l;
    event.depth = z;
    event.direction = d;
    event.throughput = throughput;
    event.hero = hero;
    event.similar = similar;
    event.flight_from_previous = from_previous;
    interactions_at_event = kind == ScatterEvent::Kind::Volume ? result.interactions : -1;
    if (on_event) on_event(event);
  };

  // ---- guided walks (WalkSettings::guiding): the current flight's mixture ----
  // A flight that starts at a volume event chose, with probability q, the guided technique for
  // its direction and its distance. Then its sampling density in channel k is the mixture
  //   p_k = (1 - q) phase_k(d) D_k + q guided_k(d) G_k,
  // D_k = sigma_t,k(l) exp(-T_k) (collision in layer l) or exp(-T_k) (leaving or reaching the
  // substrate), G_k the same with the stretched sigma_t,k (1 - mu / v0_k) and its optical depth
  // T'_k; the kernel of channel c is phase_c(d) sigma_s,c exp(-T_c) (or phase_c exp(-T_c)). So at
  // the flight's end a_c *= kernel_c / p_c and lr_k += log(p_k / p_h): the one-sample MIS over
  // techniques and channels at once. flight_q = 0 is the classic walk, bookkept as before.
  double flight_q = 0.0;
  bool flight_guided = false;          // the hero's technique for this flight
  Spectrum dir_classic, dir_guided;    // the channels' direction densities of the flight's start
  Spectrum phase_true;                 // the kernel's phase function per channel
  auto guided_flight_end = [&](const Spectrum& tau, const Spectrum& tau_g, bool collision) {
    Spectrum p, kernel_scatter, kernel_absorb;
    for (int k = 0; k < kChannels; ++k) {
      const double sigma_t = cache[l].sigma_t[k];
      const double sigma_g = guided_sigma(sigma_t, cache[l].v0[k], d.z);
      const double classic = std::exp(-tau[k]) * (collision ? sigma_t : 1.0);
      const double guided = std::exp(-tau_g[k]) * (collision ? sigma_g : 1.0);
      p[k] = (1.0 - flight_q) * dir_classic[k] * classic + flight_q * dir_guided[k] * guided;
      const double attenuation = phase_true[k] * std::exp(-tau[k]);
      kernel_scatter[k] = attenuation * (collision ? cache[l].sigma_s[k] : 1.0);
      kernel_absorb[k] = collision ? attenuation * (*layers)[l].sigma_a[k] : 0.0;
    }
    PathWeight absorbed = pw;
    for (int c = 0; c < kChannels; ++c) {
      const double ratio = p[c] > 0.0 ? pw.a[c] / p[c] : 0.0;
      absorbed.a[c] = ratio * kernel_absorb[c];
      pw.a[c] = ratio * kernel_scatter[c];
    }
    for (int k = 0; k < kChannels; ++k) {
      if (k == hero) continue;
      const double lr = p[k] > 0.0 && p[hero] > 0.0 ? std::log(p[k] / p[hero]) : -kInf;
      pw.lr[k] += lr;
      absorbed.lr[k] += lr;
    }
    if (collision && settings.tally_absorbed) result.absorbed += absorbed.value();
    flight_q = 0.0;
    flight_guided = false;
  };

  switch_if_due();  // similarity_after 0: the whole walk
  for (;;) {
    // ---- one free flight in the hero's coefficients, possibly across several interfaces ----
    double tau_left = sample_exponential(rng);
    Spectrum tau;    // optical depth of the flight so far, per channel
    Spectrum tau_g;  // guided flights: the stretched optical depth
    bool collided = false;
    while (!collided) {
      const Layer& layer = (*layers)[l];
      const Spectrum& sigma_t = cache[l].sigma_t;
      Spectrum sigma_g;  // the stretched extinction of this segment (guided flights)
      if (flight_q > 0.0)
        for (int k = 0; k < kChannels; ++k) sigma_g[k] = guided_sigma(sigma_t[k], cache[l].v0[k], d.z);
      const double rate = flight_guided ? sigma_g[hero] : sigma_t[hero];
      // The flight collides before the boundary ahead iff s = tau_left / rate < room / |d.z|
      // (room: the depth left to the boundary; a flight parallel to the layers never reaches
      // one). Compared as tau_left |d.z| < room rate: the branch, which no predictor can guess,
      // then waits for two multiplications, not two divisions. (Both sides are products of
      // non-negative numbers; room = inf in a semi-infinite layer gives inf, rate = 0 false.)
      const double room = d.z < 0.0 ? layer.thickness - z : z;
      const double mu = std::abs(d.z);
      if (rate > 0.0 && (tau_left * mu < room * rate || mu == 0.0)) {
        const double s = tau_left / rate;
        if (spectral) add_optical_depth(&tau, sigma_t, s);
        if (flight_q > 0.0) add_optical_depth(&tau_g, sigma_g, s);
        z = std::clamp(z - s * d.z, 0.0, layer.thickness);
        collided = true;
        break;
      }
      const double to_boundary = mu > 0.0 ? room / mu : kInf;
      if (to_boundary == kInf) {
        if (d.z < 0.0 && layer.semi_infinite()) {
          // Lost into the depth of a semi-infinite layer that is clear in the hero channel:
          // power transmitted downwards for good.
          if (spectral) add_optical_depth(&tau, sigma_t, kInf);
          if (flight_q > 0.0) {
            add_optical_depth(&tau_g, sigma_g, kInf);
            guided_flight_end(tau, tau_g, false);
          } else {
            flight_escaped(&pw, tau, hero);
          }
          finish_exit(WalkResult::Side::Bottom, d);
          return result;
        }
        result.end = WalkResult::End::Lost;  // parallel to the layers: never returns
        return result;
      }
      if (spectral) add_optical_depth(&tau, sigma_t, to_boundary);
      if (flight_q > 0.0) add_optical_depth(&tau_g, sigma_g, to_boundary);
      tau_left = std::max(0.0, tau_left - rate * to_boundary);
      ++result.interactions;
      const bool down = d.z < 0.0;
      z = down ? layer.thickness : 0.0;

      if (!down && l == 0 && rough) {  // rough top interface, met from inside
        // The facets seen from -d (pointing away from the surface into layer 0): reflection with
        // probability F, else refraction out; the packet keeps G2/G1 (power mode).
        const double u0 = rng.uniform(), u1 = rng.uniform(), u_choice = rng.uniform();
        const RoughDielectric::Sample sample = top.sample(-d, {u0, u1}, u_choice, true);
        // The loss tally needs the prefix's weight including this flight so far (its spectral
        // ratios are otherwise booked when the flight ends; a guided flight's are left out).
        PathWeight prefix = pw;
        if (flight_q == 0.0) flight_escaped(&prefix, tau, hero);
        const Spectrum before = prefix.value();
        pw.scale *= sample.weight;
        result.interface_loss += before * (1.0 - sample.weight);
        if (!(sample.weight > 0.0)) {
          result.end = WalkResult::End::Absorbed;
          return result;
        }
        weight = pw.value();
        if (!sample.reflected) {
          if (flight_q > 0.0) guided_flight_end(tau, tau_g, false);
          else flight_escaped(&pw, tau, hero);
          result.top_inside = d;
          finish_exit(WalkResult::Side::Top, sample.wi);
          return result;
        }
        d = sample.wi;
        reflected_since_event = true;
      } else if (!down && l == 0) {  // top interface
        const double r = fresnel_dielectric(d.z, layer.ior, stack.above_ior);
        glm::dvec3 out = d;
        if (rng.uniform() >= r && refract_through_plane(&out, layer.ior, stack.above_ior)) {
          if (flight_q > 0.0) guided_flight_end(tau, tau_g, false);
          else flight_escaped(&pw, tau, hero);
          finish_exit(WalkResult::Side::Top, out);
          return result;
        }
        d = reflect_at_plane(d);
        reflected_since_event = true;
      } else if (down && l == n_layers - 1) {  // bottom of the stack
        if (stack.below.kind == Below::Kind::Lambert) {
          // The flight ends at the substrate: a scattering event of its own kind.
          if (flight_q > 0.0) guided_flight_end(tau, tau_g, false);
          else flight_escaped(&pw, tau, hero);
          ++result.scatter_count;
          weight = pw.value();
          emit(ScatterEvent::Kind::Substrate, weight);
          // Lambert reflection sampled by cosine: f cos / pdf = (a/pi) cos / (cos/pi) = a.
          if (settings.tally_absorbed) result.absorbed += weight * (Spectrum(1.0) - stack.below.albedo);
          pw.a *= stack.below.albedo;
          weight = pw.value();
          if (weight.is_black()) {
            result.end = WalkResult::End::Absorbed;
            return result;
          }
          d = sample_cosine_hemisphere({rng.uniform(), rng.uniform()});
          if (!roulette(true)) return result;
          switch_if_due();
          break;  // a new flight
        }
        const double r = fresnel_dielectric(d.z, layer.ior, stack.below.ior);
        glm::dvec3 out = d;
        if (rng.uniform() >= r && refract_through_plane(&out, layer.ior, stack.below.ior)) {
          if (flight_q > 0.0) guided_flight_end(tau, tau_g, false);
          else flight_escaped(&pw, tau, hero);
          finish_exit(WalkResult::Side::Bottom, out);
          return result;
        }
        d = reflect_at_plane(d);
        reflected_since_event = true;
      } else {  // between two layers
        const int next = down ? l + 1 : l - 1;
        const double n_next = (*layers)[next].ior;
        const double r = fresnel_dielectric(d.z, layer.ior, n_next);
        glm::dvec3 out = d;
        if (rng.uniform() >= r && refract_through_plane(&out, layer.ior, n_next)) {
          d = out;
          l = next;
          z = down ? 0.0 : (*layers)[l].thickness;
        } else {
          d = reflect_at_plane(d);
          reflected_since_event = true;
        }
      }
      if (!roulette(false)) return result;
    }
    if (!collided) continue;  // the substrate started a new flight

    // ---- collision in layer l (see the spectral MIS notes at the top of the file) ----
    const Layer& layer = (*layers)[l];
    const Spectrum& sigma_t = cache[l].sigma_t;
    const Spectrum& sigma_s = cache[l].sigma_s;
    if (flight_q > 0.0) {
      guided_flight_end(tau, tau_g, true);
      weight = pw.value();
    } else {
    // Density of this flight in channel k relative to the hero: sigma_t,k exp(-T_k) / (...)_h.
    const Spectrum& log_sigma_t = cache[l].log_sigma_t;
    for (int k = 0; k < kChannels && spectral; ++k) {
      if (k == hero) continue;
      pw.lr[k] += sigma_t[k] > 0.0 ? log_sigma_t[k] - log_sigma_t[hero] - (tau[k] - tau[hero]) : -kInf;
    }
    // What the collision absorbs (direct tally) and scatters: the albedo splits the weight (one
    // set of spectral MIS factors for both; a grey walk's factors are 1, which values() would
    // find out by testing them).
    if (settings.tally_absorbed) {
      Spectrum absorbed_a, absorbed;
      for (int c = 0; c < kChannels; ++c) absorbed_a[c] = pw.a[c] * cache[l].absorbed_share[c];
      pw.a *= cache[l].albedo;
      if (spectral) {
        pw.values(pw.a, &weight, &absorbed_a, &absorbed);
      } else {
        weight = pw.a * pw.scale;
        absorbed = absorbed_a * pw.scale;
      }
      result.absorbed += absorbed;
    } else {
      pw.a *= cache[l].albedo;
      if (spectral) pw.values(pw.a, &weight, nullptr, nullptr);
      else weight = pw.a * pw.scale;
    }
    }
    ++result.scatter_count;
    ++result.interactions;
    if (weight.is_black()) {
      result.end = WalkResult::End::Absorbed;
      return result;
    }
    emit(ScatterEvent::Kind::Volume, weight);

    // ---- phase sampling in the hero channel: lobe, then HG (isotropic if h does not scatter) ----
    glm::dvec3 d_new;
    // The lobe's uniform only where the lobes differ in g (skin's two lobes share one g: the
    // choice could not change the direction).
    const double u0 = cache[l].one_g[hero] ? 0.0 : rng.uniform();
    const double u1 = rng.uniform(), u2 = rng.uniform();
    // Guided walks: the technique of the next flight (direction and distance), then its
    // densities for every channel, to be combined when the flight ends (guided_flight_end).
    const double q = cache[l].guiding;
    flight_guided = q > 0.0 && rng.uniform() < q;
    last_flight_guided = q > 0.0;
    if (flight_guided && cache[l].v0[hero] > 0.0) {
      const double mu = sample_dwivedi_cos(cache[l].v0[hero], u1);
      const double sin_theta = std::sqrt(std::max(0.0, (1.0 - mu) * (1.0 + mu)));
      const glm::dvec2 azimuth = unit_circle(u2);
      d_new = {sin_theta * azimuth.x, sin_theta * azimuth.y, mu};
    } else if (flight_guided) {
      d_new = sample_uniform_sphere({u1, u2});  // no channel guided here: the isotropic technique
    } else if (sigma_s[hero] > 0.0) {
      const double g = cache[l].one_g[hero] ? cache[l].g[hero] : layer.lobes[layer.choose_lobe(hero, u0)].g[hero];
      // g = 0 is isotropic: a direction on the sphere, with no frame about d to rotate into (the
      // same density 1 / (4 pi); Giovanelli's half-space, every event).
      d_new = g == 0.0 ? sample_uniform_sphere({u1, u2}) : sample_henyey_greenstein(d, g, u1, u2);
    } else {
      d_new = sample_uniform_sphere({u1, u2});
    }
    if (q > 0.0) {
      const double cos_theta = glm::dot(d, d_new);
      for (int k = 0; k < kChannels; ++k) {
        dir_classic[k] = phase_sampling_pdf(layer, k, cos_theta);
        dir_guided[k] = guided_direction_pdf(cache[l].v0[k], d_new.z);
        phase_true[k] = layer.phase(k, cos_theta);
      }
      flight_q = q;
    } else if (!cache[l].grey_phase) {
      const double cos_theta = glm::dot(d, d_new);
      const double ph = phase_sampling_pdf(layer, hero, cos_theta);
      for (int k = 0; k < kChannels; ++k)
        if (k != hero) pw.lr[k] += std::log(phase_sampling_pdf(layer, k, cos_theta) / ph);
      weight = pw.value();
    }
    d = d_new;
    if (!roulette(true)) return result;
    switch_if_due();
  }
}

}  // namespace lamina
