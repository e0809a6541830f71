// The walk kernel: the random walk's loop (random_walk.h documents the walk, random_walk.cpp
// derives it), a template over its event callback, with the spectral-MIS path weight and the
// small helpers it shares with random_walk.cpp. Public, for the two callers of the one loop:
// random_walk() (random_walk.cpp) runs it with a std::function, and the renderer's random-walk
// surface (renderer/surfaces/random_walk_surface.cpp), which connects every event to the lights,
// runs it with its own callable, which the compiler can then inline into the loop. The loop is
// kept whole: it is the hot path of `lamina brdf` and of every random-walk render.
#pragma once

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>

#include "materials/phase/dwivedi.h"
#include "materials/interfaces/fresnel.h"
#include "materials/phase/henyey_greenstein.h"
#include "materials/interfaces/microfacet.h"
#include "materials/walk/random_walk.h"
#include "materials/base/sampling.h"

namespace lamina {
namespace walk_kernel {

constexpr double kInf = std::numeric_limits<double>::infinity();

// The guided technique's extinction for a flight along direction cosine mu (with +z, towards the
// top): sigma_t (1 - mu / v0), or sigma_t where the channel is not guided.
inline double guided_sigma(double sigma_t, double v0, double mu) { return v0 > 0.0 ? sigma_t * (1.0 - mu / v0) : sigma_t; }
// Its direction density per steradian: Dwivedi's, or isotropic where the channel is not guided.
inline double guided_direction_pdf(double v0, double mu) { return v0 > 0.0 ? dwivedi_pdf(v0, mu) : kInv4Pi; }

// The sampling density of a new direction for the technique of channel k (random_walk.cpp,
// "Spectral MIS").
inline double phase_sampling_pdf(const Layer& layer, int k, double cos_theta) {
  return layer.sigma_s()[k] > 0.0 ? layer.phase(k, cos_theta) : kInv4Pi;
}

// A path's weights under the spectral MIS of random_walk.cpp: the scalar walks' weights and the
// channels' log density ratios, turned into the one-sample balance-heuristic weight by values().
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
inline void add_optical_depth(Spectrum* tau, const Spectrum& sigma_t, double length) {
  if (length <= 0.0) return;
  for (int c = 0; c < kChannels; ++c)
    if (sigma_t[c] > 0.0) (*tau)[c] += sigma_t[c] * length;
}

// lr_k += log(p_k / p_h) for a flight that left uncollided with optical depths tau.
inline void flight_escaped(PathWeight* pw, const Spectrum& tau, int hero) {
  for (int k = 0; k < kChannels; ++k)
    if (k != hero) pw->lr[k] -= tau[k] - tau[hero];
}


inline bool has_callback(const EventCallback& f) { return static_cast<bool>(f); }
template <class F>
bool has_callback(const F&) { return true; }

template <class OnEvent>
WalkResult run_walk(const WalkPlan& plan, const glm::dvec3& wi, Rng& rng, const OnEvent& on_event, int chosen_hero) {
  const LayerStack& stack = *plan.stack;
  const WalkOptions& settings = plan.settings;
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
  // A reflection at entry by an interface that decides with weight 1: the walk's exit.
  auto reflected_at_entry = [&result](const glm::dvec3& up) {
    result.side = WalkResult::Side::Top;
    result.end = WalkResult::End::ExitTop;
    result.direction = up;
    result.weight = Spectrum(1.0);
    result.entry_reflection = true;
    return result;
  };
  if (plan.diffuse_at(0)) {
    // A diffuse top (materials/interfaces/diffuse_interface.h). From its light side the walk
    // carries the transmitted part 1 - F (the specular reflection F is the caller's delta lobe,
    // as for a smooth top) in a cosine-distributed direction; from its dense side the interface
    // decides with weight 1, and a reflection is the walk's exit (entry_reflection).
    const DiffuseInterface& top_diffuse = plan.diffuse[0];
    if (stack.above_ior < n_top) {
      pw.scale = 1.0 - top_diffuse.fresnel(wi.z);
      d = sample_cosine_hemisphere({rng.uniform(), rng.uniform()});
      d.z = -d.z;
    } else {
      d = top_diffuse.sample(-wi, stack.above_ior, rng);
      if (d.z > 0.0) return reflected_at_entry(d);
    }
  } else if (plan.rough_at(0)) {
    // An energy-conserving rough top: one walk on its microsurface decides, with weight 1,
    // between the glossy reflection (the walk's exit, WalkResult::entry_reflection) and the
    // direction the light enters along.
    glm::dvec3 t;
    if (!plan.microsurfaces[0].sample(wi, rng, &t)) {
      result.end = WalkResult::End::Absorbed;
      return result;
    }
    if (t.z > 0.0) return reflected_at_entry(t);
    d = t;
  } else if (rough) {
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
  bool crossed_rough_since_event = false;  // an energy-conserving rough interface was crossed
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
      q *= std::sqrt((t - 1.0) / t);  // cumulative survival sqrt(forced_after / t), see WalkOptions
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
  // The similarity option: from the similarity_after-th event on, everything happens in the
  // similar stack. The switch falls between that event's collision (exact, like the flight that
  // led to it) and its scattering: the event is emitted as similar, and its phase function and
  // next flight are the similar stack's, so that its connections, which stand for the straight
  // exit of its next flight, go through the same stack as that flight (switching after its new
  // direction left the event's connection exact and its flight similar: the renderer's image
  // was 3-9 % darker than the walk's own exits; test
  // BrdfMonteCarlo.BinCountsAgreeWithConnectionEstimatorAcrossTheSimilaritySwitch).
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
      result.crossed_rough = crossed_rough_since_event;
      if (!settings.compute_exit_pdf || crossed_rough_since_event) return;
      const LayerStack& last_stack = stack_of_event(stack, settings, last_event);
      if ((rough || plan.rough_at(0)) && side == WalkResult::Side::Top) {
        ExitDirection exit;
        prepare_exit_through(last_stack, out, result.top_inside, &exit, settings.guiding);
        result.exit_pdf = connect_direct(last_stack, last_event, exit).pdf_hero;
      } else {
        result.exit_pdf = connection_pdf(last_stack, last_event, out, settings.guiding);
      }
    }
  };
  // Nobody reads the events of a walk with no callback that computes no exit pdf (`lamina brdf`).
  const bool keep_events = has_callback(on_event) || settings.compute_exit_pdf;
  auto emit = [&](ScatterEvent::Kind kind, const Spectrum& throughput) {
    reflected_since_event = false;
    crossed_rough_since_event = false;
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
    if (has_callback(on_event)) on_event(event);
  };

  // ---- guided walks (WalkOptions::guiding): the current flight's mixture ----
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
      // A smooth outer interface (top or bottom) into the medium of index n_out: refracted out
      // with probability 1 - R (the walk ends there: true), else reflected back in (false).
      auto leave_or_reflect = [&](double n_out, WalkResult::Side side) __attribute__((always_inline)) {
        const double r = fresnel_dielectric(d.z, layer.ior, n_out);
        glm::dvec3 out = d;
        if (rng.uniform() >= r && refract_through_plane(&out, layer.ior, n_out)) {
          if (flight_q > 0.0) guided_flight_end(tau, tau_g, false);
          else flight_escaped(&pw, tau, hero);
          finish_exit(side, out);
          return true;
        }
        d = reflect_at_plane(d);
        reflected_since_event = true;
        return false;
      };

      // An energy-conserving rough interface (materials/interfaces/microsurface.h): one walk on
      // its microsurface from -d (weight 1) reflects or transmits the packet.
      const int k_interface = down ? l + 1 : l;
      const bool no_interface = down && l == n_layers - 1 && stack.below.kind == Below::Kind::Lambert;
      const bool microsurface = plan.rough_at(k_interface) && !no_interface;
      // A diffuse interface (materials/interfaces/diffuse_interface.h) decides as a microsurface
      // does, with weight 1; the walk's density of an exit through it is never known in closed
      // form (crossed_rough), and the connections estimate those exits alone.
      const bool diffuse = plan.diffuse_at(k_interface) && !no_interface;
      glm::dvec3 crossed{0.0};
      if (microsurface && !plan.microsurfaces[k_interface].sample(-d, rng, &crossed)) {
        result.end = WalkResult::End::Absorbed;  // past MicrosurfaceDielectric::kMaxOrder
        return result;
      }
      if (diffuse) crossed = plan.diffuse[k_interface].sample(d, layer.ior, rng);
      const bool spread = microsurface || diffuse;
      const bool transmitted = spread && crossed.z * d.z > 0.0;
      if (spread && !transmitted) {
        d = crossed;
        reflected_since_event = true;
      } else if (spread && (k_interface == 0 || k_interface == n_layers)) {  // out of the stack
        if (flight_q > 0.0) guided_flight_end(tau, tau_g, false);
        else flight_escaped(&pw, tau, hero);
        // Through the top the walk's density of this exit is known (prepare_exit_through, from
        // top_inside); through the bottom it is not.
        if (k_interface == 0 && microsurface) result.top_inside = d;
        else crossed_rough_since_event = true;
        finish_exit(k_interface == 0 ? WalkResult::Side::Top : WalkResult::Side::Bottom, crossed);
        return result;
      } else if (spread) {  // into the next layer
        d = crossed;
        l = down ? l + 1 : l - 1;
        z = down ? 0.0 : (*layers)[l].thickness;
        crossed_rough_since_event = true;
      } else if (!down && l == 0 && rough) {  // rough top interface, met from inside
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
        if (leave_or_reflect(stack.above_ior, WalkResult::Side::Top)) return result;
      } else if (down && l == n_layers - 1) {  // bottom of the stack
        if (stack.below.kind == Below::Kind::Lambert) {
          // The flight ends at the substrate: a scattering event of its own kind.
          if (flight_q > 0.0) guided_flight_end(tau, tau_g, false);
          else flight_escaped(&pw, tau, hero);
          ++result.scatter_count;
          weight = pw.value();
          switch_if_due();  // the substrate is the same in both stacks; the way out is not
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
          break;  // a new flight
        }
        if (leave_or_reflect(stack.below.ior, WalkResult::Side::Bottom)) return result;
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
    const Spectrum& sigma_t = cache[l].sigma_t;
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
    switch_if_due();
    emit(ScatterEvent::Kind::Volume, weight);
    const Layer& scatterer = (*layers)[l];  // the similar stack's layer from the switch on

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
    } else if (cache[l].sigma_s[hero] > 0.0) {
      const double g = cache[l].one_g[hero] ? cache[l].g[hero] : scatterer.lobes[scatterer.choose_lobe(hero, u0)].g[hero];
      // g = 0 is isotropic: a direction on the sphere, with no frame about d to rotate into (the
      // same density 1 / (4 pi); Giovanelli's half-space, every event).
      d_new = g == 0.0 ? sample_uniform_sphere({u1, u2}) : sample_henyey_greenstein(d, g, u1, u2);
    } else {
      d_new = sample_uniform_sphere({u1, u2});
    }
    if (q > 0.0) {
      const double cos_theta = glm::dot(d, d_new);
      for (int k = 0; k < kChannels; ++k) {
        dir_classic[k] = phase_sampling_pdf(scatterer, k, cos_theta);
        dir_guided[k] = guided_direction_pdf(cache[l].v0[k], d_new.z);
        phase_true[k] = scatterer.phase(k, cos_theta);
      }
      flight_q = q;
    } else if (!cache[l].grey_phase) {
      const double cos_theta = glm::dot(d, d_new);
      const double ph = phase_sampling_pdf(scatterer, hero, cos_theta);
      for (int k = 0; k < kChannels; ++k)
        if (k != hero) pw.lr[k] += std::log(phase_sampling_pdf(scatterer, k, cos_theta) / ph);
      weight = pw.value();
    }
    d = d_new;
    if (!roulette(true)) return result;
  }
}


// The same from the stack: its plan prepared for this walk in a per-thread buffer (stacks vary
// from hit to hit on textured materials).
template <class OnEvent>
WalkResult run_walk(const LayerStack& stack, const glm::dvec3& wi, Rng& rng, const OnEvent& on_event,
                    const WalkOptions& settings, int chosen_hero) {
  thread_local WalkPlan plan;
  prepare_walk(stack, settings, &plan);
  return run_walk(plan, wi, rng, on_event, chosen_hero);
}

}  // namespace walk_kernel

}  // namespace lamina
