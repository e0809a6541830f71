#include "materials/walk/random_walk.h"
#include "materials/walk/walk_kernel.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "materials/phase/dwivedi.h"
#include "materials/interfaces/fresnel.h"
#include "materials/phase/henyey_greenstein.h"
#include "materials/interfaces/microfacet.h"
#include "materials/analytic/zeroth_order.h"

namespace lamina {

using walk_kernel::add_optical_depth;
using walk_kernel::guided_direction_pdf;
using walk_kernel::guided_sigma;
using walk_kernel::phase_sampling_pdf;

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
  // An energy-conserving top crossed along `inside` (prepare_exit_through): radiance_scale is
  // (n_above / n_0)^2 and the jacobian follows from reciprocity (prepare_exit_impl).
  bool energy_conserving = false;
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
                       const RoughCrossing* rough, Rng* rng = nullptr) {
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
  double n_ref = through_rough ? stack.layers[0].ior : n_out;
  double tx = through_rough ? rough->inside.x : w.x, ty = through_rough ? rough->inside.y : w.y;
  double mu_ref = through_rough ? rough->inside.z : mu_out;
  double sin2_ref = std::max(0.0, (1.0 - mu_ref) * (1.0 + mu_ref));
  bool crossed_microsurface = false;  // an energy-conserving rough (or a diffuse) interface lies between here and w
  // ... and the walk's density of the exit through it is known: it is the top, the only one
  // crossed (below).
  bool microsurface_density = through_rough && rough->energy_conserving;
  if (microsurface_density) crossed_microsurface = true;
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
    // The interface on this layer's way out: energy-conserving rough ones are crossed by a walk
    // on their microsurface, from the direction beyond (w, or the outer layer's inside).
    bool sampled_here = through_rough && l == 0;
    const int k_out = up ? l : l + 1;
    const double alpha = reachable && !sampled_here ? stack.energy_conserving_alpha(k_out) : 0.0;
    if (reachable && !sampled_here && stack.diffuse_interface(k_out)) {
      // A diffuse interface (materials/interfaces/diffuse_interface.h): the inside direction t is
      // sampled by cosine (density |t.z| / pi), so the crossing's estimate of the transmitted
      // radiance, f_t |t.z| / p, is pi f_t: (n_beyond / n_l)^2 (1 - F(mu_beyond)) leaving a dense
      // layer, (1 - F(mu_t)) leaving a light one. fresnel_t keeps it over the n^2 law's
      // (n_beyond / n_l)^2, which radiance_scale applies. The walk's density of its own exits
      // through it has no closed form here: jacobian 0, as behind a microsurface (random_walk.h).
      const glm::dvec3 beyond = step == 0 ? w : out->layers[up ? l - 1 : l + 1].inside;
      const double n_beyond = up ? stack.ior_above_interface(k_out) : stack.ior_below_interface(k_out);
      if (rng == nullptr) {
        reachable = false;
        continue;
      }
      const glm::dvec3 t = sample_cosine_hemisphere({rng->uniform(), rng->uniform()});
      const double mu_beyond = std::abs(beyond.z);
      const double q = n_beyond / layer.ior;
      fresnel_t *= layer.ior > n_beyond ? 1.0 - fresnel_dielectric(mu_beyond, n_beyond, layer.ior)
                                        : (1.0 - fresnel_dielectric(t.z, layer.ior, n_beyond)) / (q * q);
      n_ref = layer.ior;
      tx = t.x;
      ty = t.y;
      mu_ref = t.z;
      sin2_ref = std::max(0.0, (1.0 - mu_ref) * (1.0 + mu_ref));
      microsurface_density = false;
      sampled_here = crossed_microsurface = true;
    } else if (alpha > 0.0) {
      const glm::dvec3 beyond = step == 0 ? w : out->layers[up ? l - 1 : l + 1].inside;
      const MicrosurfaceDielectric surface{{alpha}, stack.ior_above_interface(k_out), stack.ior_below_interface(k_out)};
      glm::dvec3 t;
      if (rng == nullptr || !surface.sample(beyond, *rng, &t) || !(t.z * beyond.z < 0.0)) {
        reachable = false;
        continue;
      }
      n_ref = layer.ior;
      tx = -t.x;
      ty = -t.y;
      mu_ref = std::abs(t.z);
      sin2_ref = std::max(0.0, (1.0 - mu_ref) * (1.0 + mu_ref));
      microsurface_density = !crossed_microsurface && up && k_out == 0;
      sampled_here = crossed_microsurface = true;
    }
    const double r = n_ref / layer.ior;
    const double sin2 = r * r * sin2_ref;
    const double mu = sampled_here ? mu_ref : sin2 < 1.0 ? std::sqrt(1.0 - sin2) : -1.0;
    reachable = reachable && mu > 0.0;
    if (!reachable) continue;  // e.exists stays false, and for every layer further in
    if (!sampled_here) {
      const double n_next = up ? stack.ior_above_interface(l) : stack.ior_below_interface(l + 1);
      fresnel_t *= 1.0 - fresnel_dielectric(mu, layer.ior, n_next);
    }
    e.exists = true;
    e.inside = {tx * r, ty * r, up ? mu : -mu};
    e.mu_inside = mu;
    e.fresnel_t = fresnel_t;
    if (crossed_microsurface) {
      // The n^2 law from this layer to w, the microsurfaces' transmissions being sampled (random_walk.h).
      const double q = n_out / layer.ior;
      e.radiance_scale = fresnel_t * q * q;
      // The walk's density of leaving through the top's microsurface along w from its inside
      // direction t, over the connection's density of sampling t from w, P(w | t) / P(t | w),
      // is (n_out / n_0)^2 |w.z| / |t.z| by the microsurface's reciprocity (microsurface.h:
      // P(to | from) / (|to.z| n_to^2) is symmetric); times layer 0's refraction Jacobian to
      // this layer, (n_0 / n_l)^2 |t.z| / mu: the smooth interface's Jacobian, whatever t.
      e.jacobian = microsurface_density ? q * q * mu_out / mu : 0.0;
    } else {
      e.radiance_scale = fresnel_t * r * r * top_scale;
      e.jacobian = top_jacobian * r * r * mu_ref / mu;
    }
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
                  glm::dvec2 u_interface, Rng* rng) {
  if (!stack.single_scattering_top() || !(w.z > 0.0)) {
    prepare_exit_impl(stack, w, out, guiding, nullptr, rng);
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
  if (stack.energy_conserving_alpha(0) > 0.0 && w.z > 0.0) {
    RoughCrossing crossing;
    crossing.energy_conserving = crossing.exists = inside_up.z > 0.0;
    crossing.inside = inside_up;
    const double q = stack.above_ior / stack.layers[0].ior;
    crossing.radiance_scale = q * q;
    prepare_exit_impl(stack, w, out, guiding, &crossing);
    return;
  }
  if (!stack.single_scattering_top() || !(w.z > 0.0)) {
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
  const double distance = distance_to_exit_side(stack, event, exit);
  // A volume event's next flight is guided with probability q (WalkOptions::guiding): its
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
// = W_e p (n_out/n_l)^2 / |mu'| exp(-tau) prod(1-R): the same (tests/materials/walk/test_random_walk).
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

void prepare_walk(const LayerStack& stack, const WalkOptions& settings, WalkPlan* plan) {
  plan->stack = &stack;
  plan->settings = settings;
  const int n_layers = static_cast<int>(stack.layers.size());
  plan->may_switch = settings.similarity_after >= 0 && settings.similar != nullptr &&
                     settings.similar->layers.size() == stack.layers.size();
  plan->rough = stack.single_scattering_top();
  plan->top = plan->rough ? top_interface(stack) : RoughDielectric{};
  plan->microsurfaces_used = stack.energy_conserving_rough();
  plan->microsurfaces.clear();
  if (plan->microsurfaces_used)
    for (int k = 0; k <= n_layers; ++k)
      plan->microsurfaces.push_back({{stack.energy_conserving_alpha(k)}, stack.ior_above_interface(k), stack.ior_below_interface(k)});
  plan->diffuse_used = stack.any_diffuse_interface();
  plan->diffuse.clear();
  if (plan->diffuse_used)
    for (int k = 0; k <= n_layers; ++k)
      plan->diffuse.push_back(stack.diffuse_interface(k)
                                  ? DiffuseInterface(stack.ior_above_interface(k), stack.ior_below_interface(k))
                                  : DiffuseInterface());
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
                       const EventCallback& on_event, const WalkOptions& settings, int chosen_hero) {
  return walk_kernel::run_walk(stack, wi, rng, on_event, settings, chosen_hero);
}
WalkResult random_walk(const WalkPlan& plan, const glm::dvec3& wi, Rng& rng, const EventCallback& on_event,
                       int chosen_hero) {
  return walk_kernel::run_walk(plan, wi, rng, on_event, chosen_hero);
}

}  // namespace lamina
