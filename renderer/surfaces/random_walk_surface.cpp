#include "renderer/surfaces/random_walk_surface.h"

#include "materials/walk/walk_kernel.h"

#include <cmath>
#include <optional>
#include <vector>

#include "materials/interfaces/fresnel.h"
#include "materials/phase/henyey_greenstein.h"
#include "materials/interfaces/microfacet.h"
#include "materials/interfaces/microsurface.h"
#include "materials/walk/next_flight_connection.h"
#include "materials/walk/random_walk.h"
#include "materials/walk/walk_estimator.h"

namespace lamina {
namespace {

// Per-thread buffers of one scatter() call, reused from call to call (no allocation per hit).
struct WalkScratch {
  LayerStack similar;  // the similar stack of an approximate walk
  // Per light direction: the prepared exit (through each stack) and the factor every event's
  // connection shares.
  std::vector<ExitDirection> exits, similar_exits;
  std::vector<double> scale;
  ExitDirection own_exit;  // the exit of an event's own light sample (LightSampler)
  // Per delta light and layer: whether the layer uses next-flight connections (exact and similar
  // stack).
  std::vector<char> next_flight, similar_next_flight;
};

WalkScratch& walk_scratch() {
  thread_local WalkScratch scratch;
  return scratch;
}

// The top interface's reflection is chosen with probability r_top, the smooth Fresnel
// reflectance at wo, smooth or rough. Returns 1 if the path continues by it (*next filled), 0 if
// it ends there, -1 if the walk runs instead.
int top_reflection(const LayerStack& stack, const glm::dvec3& wo, double r_top, Rng& rng, LightDirection* lights,
                   int light_count, SurfaceScatter* next) {
  if (const double alpha = stack.energy_conserving_alpha(0); alpha > 0.0) {
    // An energy-conserving rough top (materials/interfaces/microsurface.h): its glossy lobe towards
    // every light by an unbiased estimate of the BSDF; the walk samples it (its reflection at
    // entry, WalkResult::entry_reflection, weight 1). The walk's density of that reflection has
    // no closed form, so the MIS weights use its first order, density_single, in place of it, on
    // both sides (here and in WalkScatter::run): weights that sum to 1 for every direction
    // keep the estimate unbiased whatever density they use (Veach 1997, section 9.2.2), and the
    // first order is the whole lobe at small alpha, where sampling must take the highlight.
    const MicrosurfaceDielectric top{{alpha}, stack.above_ior, stack.layers[0].ior};
    for (int k = 0; k < light_count; ++k) {
      const glm::dvec3& wl = lights[k].wi;
      if (!(wl.z > 0.0)) continue;
      const double f = top.eval(wo, wl, rng);
      if (!(f > 0.0)) continue;
      const double mis = lights[k].delta ? 1.0 : power_heuristic(lights[k].pdf, top.density_single(wo, wl));
      lights[k].f_cos += Spectrum(f * wl.z * mis);
    }
    return -1;
  }
  if (stack.single_scattering_top()) {
    // The glossy lobe of a rough top (materials/interfaces/microfacet.h): evaluated for every light
    // direction, MIS against its own sampling, which is chosen with probability r_top.
    const RoughDielectric top = top_interface(stack);
    for (int k = 0; k < light_count; ++k) {
      const glm::dvec3& wl = lights[k].wi;
      if (!(wl.z > 0.0)) continue;
      const double f = top.eval(wo, wl);
      if (!(f > 0.0)) continue;
      const double mis = lights[k].delta ? 1.0 : power_heuristic(lights[k].pdf, r_top * reflection_pdf(top.distribution, wo, wl));
      lights[k].f_cos += Spectrum(f * wl.z * mis);
    }
    if (rng.uniform() < r_top) {
      const double u0 = rng.uniform(), u1 = rng.uniform();
      glm::dvec3 wi;
      double weight;
      if (!top.sample_reflection(wo, {u0, u1}, &wi, &weight)) return 0;  // below the facets: the model's loss
      // The lobe's own weight F G2/G1 over the probability r_top of choosing it.
      next->wi = wi;
      next->weight = Spectrum(weight / r_top);
      next->pdf = r_top * reflection_pdf(top.distribution, wo, wi);
      next->delta = false;
      return next->pdf > 0.0 ? 1 : 0;
    }
  } else if (rng.uniform() < r_top) {
    next->wi = {-wo.x, -wo.y, wo.z};
    next->weight = Spectrum(1.0);
    next->pdf = 0.0;
    next->delta = true;
    return 1;
  }
  return -1;
}

// One run of the walk below the top interface: its events' light connections and its exit.
class WalkScatter {
 public:
  WalkScatter(const LayerStack& stack, const RandomWalkOptions& options, double r_top, Rng& rng, LightDirection* lights,
              int light_count, LightSampler* per_event)
      : scratch_(walk_scratch()), stack_(stack), options_(options), rng_(rng), lights_(lights), light_count_(light_count), per_event_(per_event),
        entry_(1.0 / (1.0 - r_top)), t_factor_(transmission_radiance_factor(stack)), rough_(stack.single_scattering_top()),
        microsurfaces_(stack.energy_conserving_rough()),
        n_layers_(static_cast<int>(stack.layers.size())), settings_(options) {
    settings_.tally_absorbed = false;  // the renderer never reads it
    // The similar stack of an approximate walk (built per hit: the stack may vary over the surface).
    settings_.similar = nullptr;
    if (options_.similarity_after >= 0) {
      similarity_transform_into(stack_, &scratch_.similar);
      settings_.similar = &scratch_.similar;
    }
  }

  // Prepares the light directions' exits and the next-flight layers, once per walk.
  void prepare_lights();
  // The connections of one scattering event (the walk's callback).
  void on_event(const ScatterEvent& e);
  // Runs the walk with on_event inlined into its loop and fills *next from its exit; false if
  // the walk was absorbed or killed by roulette.
  bool run(const glm::dvec3& wo, int hero, std::uint64_t* event_count, SurfaceScatter* next);

 private:
  const LayerStack& stack_of(const ScatterEvent& e) const { return stack_of_event(stack_, settings_, e); }
  Spectrum contribution(const ScatterEvent& e, const ExitDirection& exit, const LightDirection& light,
                        double light_scale, double p_a = -1.0) const;
  double light_scale(const LightDirection& light, const ExitDirection& exit) const;
  glm::dvec2 u_interface();
  bool uses_next_flight(const ScatterEvent& e, int k) const {
    return (e.similar ? scratch_.similar_next_flight : scratch_.next_flight)[k * n_layers_ + e.layer] != 0;
  }
  bool survives_roulette(double excess, double* p);
  void connect_light(const ScatterEvent& e, int k, bool switches_after, double* p_a_event);
  void connect_own_sample(const ScatterEvent& e);

  WalkScratch& scratch_;
  const LayerStack& stack_;
  const RandomWalkOptions& options_;
  Rng& rng_;
  LightDirection* lights_;
  const int light_count_;
  LightSampler* per_event_;
  const double entry_;
  const double t_factor_;
  const bool rough_;
  const bool microsurfaces_;  // energy-conserving rough interfaces: connections cross them with rng_
  const int n_layers_;
  WalkOptions settings_;  // the options as the kernel runs them at this hit
  // The walk's previous event while an event is connected, its last one afterwards. Updated at the
  // end of the callback, not copied to a `previous` first: two copies of an event whose fields the
  // walk had just stored were a visible share of the callback's time.
  ScatterEvent last_{};
  std::uint64_t events_ = 0;
};

// An event's contribution towards light direction `light` through its prepared exit.
// p_a >= 0: a next-flight technique-A connection, weighted next_flight_weight(p_a, p_b) with
// p_b the event's phase function towards the light (connect_direct's DirectExit::phase).
inline Spectrum WalkScatter::contribution(const ScatterEvent& e, const ExitDirection& exit, const LightDirection& light,
                                          double light_scale, double p_a) const {
  const DirectExit direct = connect_direct(stack_of(e), e, exit);
  if (direct.weight.is_black()) return Spectrum(0.0);
  double weight = light_scale;
  if (p_a >= 0.0) weight *= next_flight_weight(p_a, direct.phase);
  if (options_.test_hooks.naive) {
    // The naive estimator drops the Fresnel transmission of the way out.
    const double ft = exit.layers[e.layer].fresnel_t;
    if (e.kind == ScatterEvent::Kind::Volume && ft > 0.0) weight /= ft;
  } else if (!light.delta && !options_.test_hooks.connections_only) {
    weight *= power_heuristic(light.pdf, direct.pdf_for_mis);
  }
  return e.throughput * direct.weight * weight;
}

inline double WalkScatter::light_scale(const LightDirection& light, const ExitDirection& exit) const {
  return exit.layers.empty() ? 0.0 : entry_ * std::abs(light.wi.z) * (light.wi.z < 0.0 ? t_factor_ : 1.0);
}

// A rough top: each light direction's connection goes through one inside direction sampled
// from it (prepare_exit), with two uniforms of its own.
inline glm::dvec2 WalkScatter::u_interface() {
  if (!rough_) return {0.5, 0.5};
  const double u0 = rng_.uniform();
  return {u0, rng_.uniform()};
}

void WalkScatter::prepare_lights() {
  WalkScratch& s = scratch_;
  if (static_cast<int>(s.exits.size()) < light_count_) {
    s.exits.resize(light_count_);
    s.similar_exits.resize(light_count_);
  }
  s.scale.assign(light_count_, 0.0);
  for (int k = 0; k < light_count_; ++k) {
    const glm::dvec2 u = u_interface();
    Rng* crossing = microsurfaces_ ? &rng_ : nullptr;
    prepare_exit(stack_, lights_[k].wi, &s.exits[k], settings_.guiding, u, crossing);
    if (settings_.similar) prepare_exit(s.similar, lights_[k].wi, &s.similar_exits[k], settings_.guiding, u, crossing);
    s.scale[k] = light_scale(lights_[k], s.exits[k]);
  }
  // Next-flight connections: per delta light and layer, whether the layer qualifies (exact and
  // similar stack), decided once per walk.
  s.next_flight.assign(static_cast<std::size_t>(light_count_) * n_layers_, 0);
  s.similar_next_flight.assign(s.next_flight.size(), 0);
  if (options_.next_flight && !options_.test_hooks.naive && !options_.test_hooks.connections_only) {
    for (int k = 0; k < light_count_; ++k) {
      if (!lights_[k].delta || s.scale[k] == 0.0) continue;
      for (int l = 0; l < n_layers_; ++l) {
        s.next_flight[k * n_layers_ + l] = next_flight_layer(l, s.exits[k], options_.next_flight_min_g);
        if (settings_.similar) s.similar_next_flight[k * n_layers_ + l] =
            next_flight_layer(l, s.similar_exits[k], options_.next_flight_min_g);
      }
    }
  }
}

// Connection roulette. Most events of a walk in a thick medium are deep (skin: 3/4 of them
// below 0.3 mm, carrying 0.5 % of the light): an event whose way out is attenuated by more
// than exp(-D) in every channel (exit_optical_depth_bound; D = connection_roulette_depth, 6)
// is connected with probability p = exp(D - bound) and weight 1/p. Unbiased; it saves the
// phase function and the exponentials of connections that contribute next to nothing.
//
// survives_roulette(excess, &p): the roulette of a connection whose optical depth bound exceeds
// the roulette's depth by `excess`, survival p = exp(-excess) (1 when excess <= 0). A deep
// event is usually refused, and exp(-x) <= 1 / (1 + x + x^2 / 2) refuses most of those without
// the exponential: the decisions and the random numbers are the same as testing u < p. (From
// x = 1/2 on, where the two sides differ by far more than rounding.)
inline bool WalkScatter::survives_roulette(double excess, double* p) {
  *p = 1.0;
  if (!(excess > 0.0)) return true;
  if (excess < 0.5) {
    *p = std::exp(-excess);
    return *p >= 1.0 || rng_.uniform() < *p;
  }
  const double u = rng_.uniform();
  if (u * (1.0 + excess * (1.0 + 0.5 * excess)) >= 1.0) return false;
  *p = std::exp(-excess);
  return u < *p;
}

// Event e's connections to light direction k: next-flight technique B from e, then e's own
// connection (technique A) through the depth and phase roulettes.
inline void WalkScatter::connect_light(const ScatterEvent& e, int k, bool switches_after, double* p_a_event) {
  const WalkScratch& s = scratch_;
  const ExitDirection& exit = e.similar ? s.similar_exits[k] : s.exits[k];
  const bool split = uses_next_flight(e, k);
  // Technique B from this event: the next flight's connection along a direction drawn
  // around the light's inside direction, with its own roulette on depth.
  if (split && e.kind == ScatterEvent::Kind::Volume && !switches_after) {
    double p;
    if (survives_roulette(next_flight_depth_bound(stack_of(e), e, exit) - options_.next_flight_roulette_depth, &p)) {
      const double u1 = rng_.uniform(), u2 = rng_.uniform();
      lights_[k].f_cos += e.throughput * next_flight_connection(stack_of(e), e, exit, u1, u2) * (s.scale[k] / p);
    }
  }
  double p;
  if (!survives_roulette(exit_optical_depth_bound(stack_of(e), e, exit) - options_.connection_roulette_depth, &p)) return;
  // The phase roulette (RandomWalkOptions::connection_phase_roulette): below the isotropic
  // value (times the option) a connection is made with probability p_phase / p_ref.
  const ExitDirection::LayerExit& path = exit.layers[e.layer];
  const double phase_ref = options_.connection_phase_roulette * kInv4Pi;
  if (phase_ref > 0.0 && lights_[k].delta && e.kind == ScatterEvent::Kind::Volume && path.single_lobe) {
    const double q = henyey_greenstein(glm::dot(e.direction, path.inside), path.single_g) / phase_ref;
    if (q < 1.0) {
      if (!(rng_.uniform() < q)) return;
      p *= q;
    }
  }
  // Technique A: this event's own connection, weighted against B when its flight came
  // straight from the previous event (p_A, the density of its direction, is the same for
  // every light).
  double p_a = -1.0;
  if (split && e.flight_from_previous) {
    if (!(*p_a_event >= 0.0)) *p_a_event = next_flight_direction_pdf(last_, e, path.single_g);
    p_a = *p_a_event;
  }
  lights_[k].f_cos += contribution(e, exit, lights_[k], s.scale[k] / p, p_a);
}

// With a LightSampler: the event's own light sample, with its own shadow ray.
inline void WalkScatter::connect_own_sample(const ScatterEvent& e) {
  LightDirection own;
  if (per_event_ && per_event_->draw(rng_, &own)) {
    prepare_exit(stack_of(e), own.wi, &scratch_.own_exit, settings_.guiding, u_interface(), microsurfaces_ ? &rng_ : nullptr);
    const double own_scale = light_scale(own, scratch_.own_exit);
    if (own_scale != 0.0) {
      const Spectrum c = contribution(e, scratch_.own_exit, own, own_scale);
      if (!c.is_black()) per_event_->add(c);
    }
  }
}

inline void WalkScatter::on_event(const ScatterEvent& e) {
  ++events_;
  double p_a_event = -1.0;  // next-flight technique A's p_A, computed once per event
  // Technique B never starts from the last exact event before the walk switches to the similar
  // stack: the collision its next flight ends in is the switch's event, which scatters and
  // leaves through the similar stack, not the exact one that B integrates (the walk switches
  // between that event's collision and its scattering: materials/walk/walk_kernel.h).
  const bool switches_after = settings_.similar && !e.similar && e.order + 1 >= settings_.similarity_after;
  for (int k = 0; k < light_count_; ++k) {
    if (scratch_.scale[k] == 0.0) continue;
    connect_light(e, k, switches_after, &p_a_event);
  }
  connect_own_sample(e);
  last_ = e;
}

bool WalkScatter::run(const glm::dvec3& wo, int hero, std::uint64_t* event_count, SurfaceScatter* next) {
  auto on_event_cb = [this](const ScatterEvent& e) { on_event(e); };
  // The walk's loop with this callback inlined into it (materials/walk/walk_kernel.h).
  const WalkResult walk = walk_kernel::run_walk(stack_, wo, rng_, on_event_cb, settings_, hero);
  if (event_count) *event_count += events_;
  if (walk.side == WalkResult::Side::None) return false;  // absorbed or killed by roulette
  next->wi = walk.direction;
  next->weight = walk.weight * entry_;
  if (walk.side == WalkResult::Side::Bottom) next->weight *= t_factor_;
  next->delta = true;
  next->pdf = 0.0;
  if (walk.entry_reflection) {
    // The glossy reflection of an energy-conserving rough top: MIS density as in top_reflection.
    next->delta = false;
    next->pdf = MicrosurfaceDielectric{{stack_.top_roughness}, stack_.above_ior, stack_.layers[0].ior}.density_single(wo, walk.direction);
  } else if (walk.straight_from_last_event && walk.crossed_rough) {
    // Through energy-conserving rough interfaces other than the top the light connections
    // estimate the direct light alone (WalkResult::crossed_rough): pdf 0 gives this exit weight 0
    // on an emitter. (Through the top alone, the branch below weights it by its density.)
    next->delta = false;
  } else if (walk.straight_from_last_event && !options_.test_hooks.naive) {
    next->delta = false;
    // connections_only: pdf 0 gives such an exit weight 0 on an emitter.
    next->pdf = options_.test_hooks.connections_only ? 0.0 : exit_pdf_for_mis(stack_of(last_), last_, walk.direction, settings_.guiding, walk.top_inside);
  }
  return true;
}

// A LightSampler whose added estimates are multiplied by per-channel factors first
// (RandomWalkSurface::follow_one_wavelength).
class WeightedLightSampler final : public LightSampler {
 public:
  WeightedLightSampler(LightSampler* inner, const Spectrum& weights) : inner_(inner), weights_(weights) {}
  bool draw(Rng& rng, LightDirection* light) override { return inner_->draw(rng, light); }
  void add(const Spectrum& f_cos) override { inner_->add(f_cos * weights_); }

 private:
  LightSampler* inner_;
  Spectrum weights_;
};

}  // namespace

bool RandomWalkSurface::scatter(const glm::dvec3& wo, Rng& rng, LightDirection* lights, int light_count,
                                LightSampler* per_event, SurfaceScatter* next) const {
  if (one_wavelength_) {
    std::optional<WeightedLightSampler> weighted;
    if (per_event) weighted.emplace(per_event, channel_weights_);
    const bool continues = scatter_all(wo, rng, lights, light_count, weighted ? &*weighted : nullptr, next);
    for (int k = 0; k < light_count; ++k) lights[k].f_cos *= channel_weights_;
    if (continues) next->weight *= channel_weights_;
    return continues;
  }
  return scatter_all(wo, rng, lights, light_count, per_event, next);
}

bool RandomWalkSurface::scatter_all(const glm::dvec3& wo, Rng& rng, LightDirection* lights, int light_count,
                                    LightSampler* per_event, SurfaceScatter* next) const {
  for (int k = 0; k < light_count; ++k) lights[k].f_cos = Spectrum(0.0);
  // The top's reflection chosen with probability r_top before the walk; an energy-conserving
  // rough top is the walk's own (r_top 0: the walk takes every path).
  const double r_top = stack_.energy_conserving_alpha(0) > 0.0 ? 0.0 : fresnel_dielectric(wo.z, stack_.above_ior, stack_.layers[0].ior);
  const int reflected = top_reflection(stack_, wo, r_top, rng, lights, light_count, next);
  if (reflected >= 0) return reflected == 1;
  WalkScatter walk(stack_, options_, r_top, rng, lights, light_count, per_event);
  walk.prepare_lights();
  return walk.run(wo, hero_, events_, next);
}

bool WavelengthWalksSurface::scatter(const glm::dvec3& wo, Rng& rng, LightDirection* lights, int light_count,
                                     LightSampler* per_event, SurfaceScatter* next) const {
  thread_local std::vector<LightDirection> own;  // one walk's connections
  own.assign(lights, lights + light_count);
  for (int k = 0; k < light_count; ++k) lights[k].f_cos = Spectrum(0.0);
  bool continues = false;
  for (int c = 0; c < kChannels; ++c) {
    RandomWalkSurface walk(stacks_[c], c, options_, events_);
    walk.follow_one_wavelength(c, 1.0);
    SurfaceScatter exit;
    const bool walk_continues = walk.scatter(wo, rng, own.data(), light_count, per_event, &exit);
    for (int k = 0; k < light_count; ++k) lights[k].f_cos += own[k].f_cos;
    if (c != follow_) continue;
    continues = walk_continues;
    if (continues) {
      *next = exit;
      next->weight *= static_cast<double>(kChannels);
    }
  }
  return continues;
}

}  // namespace lamina
