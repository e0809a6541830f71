#include "renderer/surfaces/random_walk_surface.h"

#include "materials/walk/walk_kernel.h"

#include <cmath>
#include <optional>
#include <vector>

#include "materials/interfaces/diffuse_interface.h"
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

// Slot 1: the walk upwards from a diffusely transmitting bottom (scatter_through_diffuse), which
// runs beside slot 0's.
WalkScratch& walk_scratch(int slot = 0) {
  thread_local WalkScratch scratch[2];
  return scratch[slot];
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

// A diffuse interface (materials/interfaces/diffuse_interface.h) crossed from the side of index
// n_from: the probability of crossing at |cos| mu_from, and the density per steradian of the
// direction beyond (|cos| mu_to): from the light side the cosine, from the dense side exit_pdf.
// The direction beyond does not depend on the one the light arrived along: f |cos w| =
// transmittance x pdf(w), whatever the arrival.
double crossing_transmittance(const DiffuseInterface& i, double n_from, double mu_from) {
  return n_from == i.n_lo ? 1.0 - i.fresnel(mu_from) : i.t_hi;
}
double crossing_pdf(const DiffuseInterface& i, double n_from, double mu_to) {
  return n_from == i.n_lo ? mu_to * kInvPi : i.exit_pdf(mu_to);
}
// Its Lambertian reflection back to the side of n_from: 1 - t_hi from the dense side, none from the
// light side (a specular reflection there).
double diffuse_reflectance(const DiffuseInterface& i, double n_from) { return n_from == i.n_hi ? 1.0 - i.t_hi : 0.0; }

// A point of a diffuse outer interface that sends light into the stack along a direction of its
// own drawing (scatter_through_diffuse): the camera's entry through it, or its Lambertian
// reflection of light arriving from the dense side. In the frame of the walk that starts there it
// lies at the walk's top and emits downwards into the walk's first layer with density
// pdf(mu) per steradian, weight factor (the reflection's probability 1 - t_hi; 1 for the entry,
// whose choice the camera's path made).
struct SurfaceSource {
  DiffuseInterface iface;
  double n_from = 1.0;     // the index the light came from
  bool reflected = false;  // a reflection (the cosine) or a crossing (crossing_pdf)
  double factor = 1.0;
  double pdf(double mu) const { return reflected ? mu * kInvPi : crossing_pdf(iface, n_from, mu); }
};

// How a walk's stack sits in the surface's frame when the surface has diffusely transmitting
// outer interfaces (scatter_through_diffuse): the walk runs on the stack with those interfaces
// index-matched, possibly upside down (flip: its +z is the surface's -z), and its events connect
// to no light beyond a diffuse side (blocked_up: the surface's +z, blocked_down: -z).
struct WalkFrame {
  bool flip = false;
  bool blocked_up = false, blocked_down = false;
  double entry = 1.0;     // the factor of every estimate (1 / (1 - r_top) for a smooth top)
  double t_factor = 1.0;  // transmission_radiance_factor of the surface's stack
};

// One run of the walk below the top interface: its events' light connections and its exit.
class WalkScatter {
 public:
  WalkScatter(const LayerStack& stack, const RandomWalkOptions& options, double r_top, Rng& rng, LightDirection* lights,
              int light_count, LightSampler* per_event)
      : WalkScatter(stack, options, rng, lights, light_count, per_event,
                    WalkFrame{false, false, false, 1.0 / (1.0 - r_top), transmission_radiance_factor(stack)}, 0) {}
  WalkScatter(const LayerStack& stack, const RandomWalkOptions& options, Rng& rng, LightDirection* lights, int light_count,
              LightSampler* per_event, const WalkFrame& frame, int scratch_slot)
      : scratch_(walk_scratch(scratch_slot)), stack_(stack), options_(options), rng_(rng), lights_(lights), light_count_(light_count), per_event_(per_event),
        frame_(frame), entry_(frame.entry), t_factor_(frame.t_factor), rough_(stack.single_scattering_top()),
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
  // One run (scatter_through_diffuse) whose events' throughputs are multiplied by `carried`,
  // wi in the walk's own frame; the caller reads the exit.
  WalkResult run_carried(const glm::dvec3& wi, int hero, const Spectrum& carried, std::uint64_t* event_count);
  // The MIS density (and delta flag) of the walk's exit `walk`, which entered along wo.
  void exit_density(const WalkResult& walk, const glm::dvec3& wo, SurfaceScatter* next) const;
  // A source at the walk's top (scatter_through_diffuse) as an event of weight `carried`: its
  // connections to the lights beyond the walk's bottom and its own light sample.
  void connect_source(const SurfaceSource& source, const Spectrum& carried);
  // The MIS density of the walk's exit straight from that source along w (the walk's frame; no
  // reflection, no scattering on the way).
  double source_exit_pdf(const SurfaceSource& source, const glm::dvec3& w) const;
  // A light direction in the walk's frame.
  glm::dvec3 to_walk(const glm::dvec3& w) const { return frame_.flip ? glm::dvec3(w.x, w.y, -w.z) : w; }

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
  const WalkFrame frame_;
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
  if (light.wi.z > 0.0 ? frame_.blocked_up : frame_.blocked_down) return 0.0;  // beyond a diffuse side
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
    const glm::dvec3 wl = to_walk(lights_[k].wi);
    prepare_exit(stack_, wl, &s.exits[k], settings_.guiding, u, crossing);
    if (settings_.similar) prepare_exit(s.similar, wl, &s.similar_exits[k], settings_.guiding, u, crossing);
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

// A source emits downwards from the top of the walk's first layer, like a Lambert substrate
// upside down: towards a prepared direction below, connect_direct's substrate emission with
// factor x pdf(mu) / mu in place of albedo / pi, and the walk's own density of that way out,
// factor x pdf(mu) exp(-tau) x jacobian x Fresnel transmissions (the mean over the heroes).
DirectExit source_connection(const LayerStack& stack, const SurfaceSource& source, const ExitDirection& exit) {
  DirectExit out;
  if (exit.layers.empty() || exit.up || !exit.layers[0].exists) return out;
  const ExitDirection::LayerExit& path = exit.layers[0];
  const double sampling = source.factor * source.pdf(path.mu_inside), emission = sampling / path.mu_inside;
  const double distance = stack.layers[0].thickness;
  double pdf_sum = 0.0;
  for (int c = 0; c < kChannels; ++c) {
    const double tau = path.tau_beyond[c] + (path.depth_rate[c] > 0.0 ? path.depth_rate[c] * distance : 0.0);
    const double transmittance = std::exp(-tau);
    out.weight[c] = emission * transmittance * path.radiance_scale;
    pdf_sum += sampling * transmittance * path.jacobian * path.fresnel_t;
  }
  out.pdf_for_mis = pdf_sum / kChannels;
  return out;
}

void WalkScatter::connect_source(const SurfaceSource& source, const Spectrum& carried) {
  auto add = [&](const LightDirection& light, const ExitDirection& exit, double scale) -> Spectrum {
    if (scale == 0.0) return Spectrum(0.0);
    const DirectExit direct = source_connection(stack_, source, exit);
    const double mis = light.delta ? 1.0 : power_heuristic(light.pdf, direct.pdf_for_mis);
    return carried * direct.weight * (scale * mis);
  };
  for (int k = 0; k < light_count_; ++k) lights_[k].f_cos += add(lights_[k], scratch_.exits[k], scratch_.scale[k]);
  LightDirection own;
  if (per_event_ && per_event_->draw(rng_, &own)) {
    prepare_exit(stack_, to_walk(own.wi), &scratch_.own_exit, settings_.guiding, u_interface(), microsurfaces_ ? &rng_ : nullptr);
    const Spectrum c = add(own, scratch_.own_exit, light_scale(own, scratch_.own_exit));
    if (!c.is_black()) per_event_->add(c);
  }
}

double WalkScatter::source_exit_pdf(const SurfaceSource& source, const glm::dvec3& w) const {
  ExitDirection exit;
  prepare_exit(stack_, w, &exit, settings_.guiding);
  return source_connection(stack_, source, exit).pdf_for_mis;
}

// With a LightSampler: the event's own light sample, with its own shadow ray.
inline void WalkScatter::connect_own_sample(const ScatterEvent& e) {
  LightDirection own;
  if (per_event_ && per_event_->draw(rng_, &own)) {
    prepare_exit(stack_of(e), to_walk(own.wi), &scratch_.own_exit, settings_.guiding, u_interface(), microsurfaces_ ? &rng_ : nullptr);
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
  exit_density(walk, wo, next);
  return true;
}

WalkResult WalkScatter::run_carried(const glm::dvec3& wi, int hero, const Spectrum& carried, std::uint64_t* event_count) {
  auto on_event_cb = [this, &carried](const ScatterEvent& e) {
    ScatterEvent scaled = e;
    scaled.throughput *= carried;
    on_event(scaled);
  };
  const WalkResult walk = walk_kernel::run_walk(stack_, wi, rng_, on_event_cb, settings_, hero);
  if (event_count) *event_count += events_;
  events_ = 0;
  return walk;
}

void WalkScatter::exit_density(const WalkResult& walk, const glm::dvec3& wo, SurfaceScatter* next) const {
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

// Whether the walk meets a diffusely transmitting interface on the stack's outside: the top, or
// the bottom of a stack that transmits.
bool diffuse_top(const LayerStack& stack) { return stack.diffuse_interface(0); }
bool diffuse_bottom(const LayerStack& stack) {
  return stack.transmits() && stack.diffuse_interface(static_cast<int>(stack.layers.size()));
}

// An arrival at a diffuse outer interface from inside (side +1 the top, -1 the bottom) as an
// emitter through it: f |cos| towards light direction wl is T pdf(wl) (crossing_transmittance
// times crossing_pdf), times the MIS weight against the arrival's own crossing, whose density is
// that same product.
Spectrum arrival_connection(const DiffuseInterface& iface, double n_in, double transmit, double side,
                            const LightDirection& light, const Spectrum& scale) {
  if (!(light.wi.z * side > 0.0)) return Spectrum(0.0);
  const double f_cos = transmit * crossing_pdf(iface, n_in, std::abs(light.wi.z));
  const double mis = light.delta ? 1.0 : power_heuristic(light.pdf, f_cos);
  return scale * (f_cos * mis);
}

// The camera's entry through a diffuse top from outside: with the interface's own probabilities,
// its reflection (specular from the light side: the delta lobe; Lambertian from the dense side,
// connected to the lights above and MIS against its own sample) or the crossing into the stack
// (returns false, *inside the direction, *source the entry).
bool diffuse_entry(const LayerStack& stack, const DiffuseInterface& iface, const glm::dvec3& wo, Rng& rng,
                   LightDirection* lights, int light_count, LightSampler* per_event, SurfaceScatter* next,
                   glm::dvec3* inside, std::optional<SurfaceSource>* source) {
  const double r_diffuse = diffuse_reflectance(iface, stack.above_ior);
  auto lobe = [&](const LightDirection& light) {
    if (!(r_diffuse > 0.0 && light.wi.z > 0.0)) return Spectrum(0.0);
    const double f_cos = r_diffuse * light.wi.z * kInvPi;
    return Spectrum(f_cos * (light.delta ? 1.0 : power_heuristic(light.pdf, f_cos)));
  };
  for (int k = 0; k < light_count; ++k) lights[k].f_cos += lobe(lights[k]);
  LightDirection own;
  if (r_diffuse > 0.0 && per_event && per_event->draw(rng, &own)) {
    const Spectrum c = lobe(own);
    if (!c.is_black()) per_event->add(c);
  }
  const glm::dvec3 d = iface.sample(-wo, stack.above_ior, rng);
  if (d.z > 0.0) {
    next->wi = d;
    next->weight = Spectrum(1.0);
    next->delta = !(r_diffuse > 0.0);
    next->pdf = next->delta ? 0.0 : r_diffuse * d.z * kInvPi;
    return true;
  }
  *inside = d;
  *source = SurfaceSource{iface, stack.above_ior, false, 1.0};
  return false;
}

// The surface of a stack with a diffuse top or bottom (docs/layered_rendering.md, "Diffusely
// transmitting interfaces"). Such an interface forgets the direction it is crossed in, so no
// light connection can refract through it: the walk runs on the stack with it index-matched
// (`inner`), and each time the walk reaches it from inside, that ARRIVAL is a surface emitting
// what reached it, with f |cos| = T pdf through the interface: it connects to the lights on that
// side like a diffuse BSDF, MIS against its own crossing, which the interface's sampling then
// takes or not. From the dense side its Lambertian reflection (1 - t_hi) is a source too: it
// connects, through the stack, to the lights beyond the other side, as the camera's entry through a
// diffuse top does, MIS against the next walk's exit straight from it. A walk that starts at the
// bottom runs on the flipped inner stack; each carries the weight so far. The scattering events
// connect only to the lights beyond smooth or rough sides (WalkFrame::blocked_*).
bool scatter_through_diffuse(const LayerStack& stack, const RandomWalkOptions& options, int hero, std::uint64_t* events,
                             const glm::dvec3& wo, Rng& rng, LightDirection* lights, int light_count,
                             LightSampler* per_event, SurfaceScatter* next) {
  const int n = static_cast<int>(stack.layers.size());
  const bool top = diffuse_top(stack), bottom = diffuse_bottom(stack);
  const double n_first = stack.layers[0].ior, n_last = stack.layers[n - 1].ior;
  thread_local LayerStack inner, inner_flipped;
  inner = stack;
  inner.top_diffuse = false;
  for (Layer& layer : inner.layers) layer.bottom_diffuse = false;
  if (top) inner.above_ior = n_first;
  if (bottom) inner.below.ior = n_last;
  WalkFrame frame;
  frame.blocked_up = top;
  frame.blocked_down = bottom;
  frame.t_factor = transmission_radiance_factor(stack);
  const DiffuseInterface top_iface(stack.above_ior, n_first), bottom_iface(n_last, stack.below.ior);
  glm::dvec3 wi = wo;  // the next walk's incidence, in its own frame
  std::optional<SurfaceSource> source;  // where the next walk starts, if that is a source
  if (top) {
    glm::dvec3 inside;
    if (diffuse_entry(stack, top_iface, wo, rng, lights, light_count, per_event, next, &inside, &source)) return true;
    wi = -inside;
  } else {
    const double r_top = stack.energy_conserving_alpha(0) > 0.0 ? 0.0 : fresnel_dielectric(wo.z, stack.above_ior, n_first);
    const int reflected = top_reflection(stack, wo, r_top, rng, lights, light_count, next);
    if (reflected >= 0) return reflected == 1;
    frame.entry = 1.0 / (1.0 - r_top);
  }
  WalkScatter down(inner, options, rng, lights, light_count, per_event, frame, 0);
  down.prepare_lights();
  std::optional<WalkScatter> up;  // walks from the bottom upwards, on the flipped inner stack
  auto walk_from = [&](bool from_top) -> WalkScatter& {
    if (!from_top && !up) {
      flip_into(inner, &inner_flipped);
      WalkFrame flipped_frame = frame;
      flipped_frame.flip = true;
      up.emplace(inner_flipped, options, rng, lights, light_count, per_event, flipped_frame, 1);
      up->prepare_lights();
    }
    return from_top ? down : *up;
  };
  Spectrum carried(1.0);
  if (source) down.connect_source(*source, carried);
  WalkScatter* walk = &down;
  // Every arrival crosses with probability >= min(t_hi, 1 - F) > 0 and the roulette below ends
  // the rest: the bound only guards against a degenerate stack.
  for (int arrival = 0; arrival < 1000000; ++arrival) {
    // The caller's hero for the first walk alone: a walk's weights are unbiased averaged over its
    // hero, so the walks whose weights multiply must draw theirs independently.
    const WalkResult r = walk->run_carried(wi, arrival == 0 ? hero : kRandomHero, carried, events);
    if (r.side == WalkResult::Side::None) return false;
    const glm::dvec3 dir = walk->to_walk(r.direction);  // in the surface's frame (to_walk is its own inverse)
    const bool at_top = dir.z > 0.0;
    const Spectrum scale = Spectrum(frame.entry * (at_top ? 1.0 : frame.t_factor));
    if (!(at_top ? top : bottom)) {  // out through a smooth or rough side
      next->wi = dir;
      next->weight = r.weight * carried * scale;
      walk->exit_density(r, wi, next);
      // Straight from a source (no interaction but the n interfaces crossed): its connection's
      // MIS partner.
      if (source && r.scatter_count == 0 && r.interactions == n) {
        next->delta = false;
        next->pdf = options.test_hooks.connections_only ? 0.0 : walk->source_exit_pdf(*source, r.direction);
      }
      return true;
    }
    carried *= r.weight;
    const DiffuseInterface& iface = at_top ? top_iface : bottom_iface;
    const double n_in = at_top ? n_first : n_last, side = at_top ? 1.0 : -1.0;
    const double transmit = crossing_transmittance(iface, n_in, std::abs(dir.z));
    for (int k = 0; k < light_count; ++k)
      lights[k].f_cos += carried * arrival_connection(iface, n_in, transmit, side, lights[k], scale);
    LightDirection own;
    if (per_event && per_event->draw(rng, &own)) {
      const Spectrum c = carried * arrival_connection(iface, n_in, transmit, side, own, scale);
      if (!c.is_black()) per_event->add(c);
    }
    WalkScatter& back = walk_from(at_top);  // the walk that starts here
    source.reset();
    if (const double r_diffuse = diffuse_reflectance(iface, n_in); r_diffuse > 0.0) {
      source = SurfaceSource{iface, n_in, true, r_diffuse};
      back.connect_source(*source, carried);
    }
    const glm::dvec3 d = iface.sample(dir, n_in, rng);
    if (d.z * dir.z > 0.0) {  // crossed
      next->wi = d;
      next->weight = carried * scale;
      next->pdf = transmit * crossing_pdf(iface, n_in, std::abs(d.z));
      next->delta = false;
      return true;
    }
    // Reflected back in: Russian roulette on the carried weight, as the walk's own.
    if (carried.max() < options.roulette_threshold) {
      if (!(rng.uniform() < options.roulette_survival)) return false;
      carried /= options.roulette_survival;
    }
    walk = &back;
    wi = -walk->to_walk(d);
  }
  return false;
}

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
  if (diffuse_top(stack_) || diffuse_bottom(stack_))
    return scatter_through_diffuse(stack_, options_, hero_, events_, wo, rng, lights, light_count, per_event, next);
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
