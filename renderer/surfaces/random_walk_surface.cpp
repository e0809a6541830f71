#include "renderer/surfaces/random_walk_surface.h"

#include "materials/walk/walk_kernel.h"

#include <cmath>
#include <vector>

#include "materials/interfaces/fresnel.h"
#include "materials/phase/henyey_greenstein.h"
#include "materials/interfaces/microfacet.h"
#include "materials/walk/next_flight_connection.h"
#include "materials/walk/random_walk.h"
#include "materials/walk/walk_estimator.h"

namespace lamina {

bool RandomWalkSurface::scatter(const glm::dvec3& wo, Rng& rng, LightDirection* lights, int light_count,
                                LightSampler* per_event, SurfaceScatter* next) const {
  for (int k = 0; k < light_count; ++k) lights[k].f_cos = Spectrum(0.0);
  // The top interface's reflection is chosen with probability r_top, the smooth Fresnel
  // reflectance at wo, smooth or rough.
  const double r_top = fresnel_dielectric(wo.z, stack_.above_ior, stack_.layers[0].ior);
  const bool rough = stack_.rough_top();
  if (rough) {
    // The glossy lobe of a rough top (materials/interfaces/microfacet.h): evaluated for every light
    // direction, MIS against its own sampling, which is chosen with probability r_top.
    const RoughDielectric top = top_interface(stack_);
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
      if (!top.sample_reflection(wo, {u0, u1}, &wi, &weight)) return false;  // below the facets: the model's loss
      // The lobe's own weight F G2/G1 over the probability r_top of choosing it.
      next->wi = wi;
      next->weight = Spectrum(weight / r_top);
      next->pdf = r_top * reflection_pdf(top.distribution, wo, wi);
      next->delta = false;
      return next->pdf > 0.0;
    }
  } else if (rng.uniform() < r_top) {
    next->wi = {-wo.x, -wo.y, wo.z};
    next->weight = Spectrum(1.0);
    next->pdf = 0.0;
    next->delta = true;
    return true;
  }
  const double entry = 1.0 / (1.0 - r_top);
  const double t_factor = transmission_radiance_factor(stack_);
  // The similar stack of an approximate walk (built per hit: the stack may vary over the surface).
  WalkSettings settings;
  settings.guiding = options_.guiding;
  settings.roulette_threshold = options_.roulette_threshold;
  settings.roulette_survival = options_.roulette_survival;
  settings.tally_absorbed = false;
  thread_local LayerStack similar;
  if (options_.similarity_after >= 0) {
    similarity_transform_into(stack_, &similar);
    settings.similarity_after = options_.similarity_after;
    settings.similar = &similar;
  }
  auto stack_of = [&](const ScatterEvent& e) -> const LayerStack& { return stack_of_event(stack_, settings, e); };
  // Per light direction: the prepared exit (through each stack) and the factor every event's
  // connection shares.
  thread_local std::vector<ExitDirection> exits, similar_exits;
  thread_local std::vector<double> scale;
  if (static_cast<int>(exits.size()) < light_count) {
    exits.resize(light_count);
    similar_exits.resize(light_count);
  }
  scale.assign(light_count, 0.0);

  // An event's contribution towards light direction `light` through its prepared exit.
  // p_a >= 0: a next-flight technique-A connection, weighted next_flight_weight(p_a, p_b) with
  // p_b the event's phase function towards the light (connect_direct's DirectExit::phase).
  auto contribution = [&](const ScatterEvent& e, const ExitDirection& exit, const LightDirection& light,
                          double light_scale, double p_a = -1.0) {
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
  };
  auto light_scale = [&](const LightDirection& light, const ExitDirection& exit) {
    return exit.layers.empty() ? 0.0 : entry * std::abs(light.wi.z) * (light.wi.z < 0.0 ? t_factor : 1.0);
  };
  // A rough top: each light direction's connection goes through one inside direction sampled
  // from it (prepare_exit), with two uniforms of its own.
  auto u_interface = [&]() -> glm::dvec2 {
    if (!rough) return {0.5, 0.5};
    const double u0 = rng.uniform();
    return {u0, rng.uniform()};
  };
  for (int k = 0; k < light_count; ++k) {
    const glm::dvec2 u = u_interface();
    prepare_exit(stack_, lights[k].wi, &exits[k], settings.guiding, u);
    if (settings.similar) prepare_exit(similar, lights[k].wi, &similar_exits[k], settings.guiding, u);
    scale[k] = light_scale(lights[k], exits[k]);
  }
  thread_local ExitDirection own_exit;
  // Next-flight connections: per delta light and layer, whether the layer qualifies (exact and
  // similar stack), decided once per walk.
  const int n_layers = static_cast<int>(stack_.layers.size());
  thread_local std::vector<char> next_flight, similar_next_flight;
  next_flight.assign(static_cast<std::size_t>(light_count) * n_layers, 0);
  similar_next_flight.assign(next_flight.size(), 0);
  if (options_.next_flight && !options_.test_hooks.naive && !options_.test_hooks.connections_only) {
    for (int k = 0; k < light_count; ++k) {
      if (!lights[k].delta || scale[k] == 0.0) continue;
      for (int l = 0; l < n_layers; ++l) {
        next_flight[k * n_layers + l] = next_flight_layer(l, exits[k], options_.next_flight_min_g);
        if (settings.similar) similar_next_flight[k * n_layers + l] =
            next_flight_layer(l, similar_exits[k], options_.next_flight_min_g);
      }
    }
  }
  auto uses_next_flight = [&](const ScatterEvent& e, int k) {
    return (e.similar ? similar_next_flight : next_flight)[k * n_layers + e.layer] != 0;
  };

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
  auto survives_roulette = [&](double excess, double* p) {
    *p = 1.0;
    if (!(excess > 0.0)) return true;
    if (excess < 0.5) {
      *p = std::exp(-excess);
      return *p >= 1.0 || rng.uniform() < *p;
    }
    const double u = rng.uniform();
    if (u * (1.0 + excess * (1.0 + 0.5 * excess)) >= 1.0) return false;
    *p = std::exp(-excess);
    return u < *p;
  };
  const double roulette_depth = options_.connection_roulette_depth;
  const double phase_ref = options_.connection_phase_roulette * kInv4Pi;

  // The walk's previous event while an event is connected, its last one afterwards. Updated at the
  // end of the callback, not copied to a `previous` first: two copies of an event whose fields the
  // walk had just stored were a visible share of the callback's time.
  ScatterEvent last{};
  std::uint64_t events = 0;
  auto on_event = [&](const ScatterEvent& e) {
    ++events;
    double p_a_event = -1.0;  // next-flight technique A's p_A, computed once per event
    // Technique B never starts from the last exact event before the walk switches to the similar
    // stack: the collision its next flight ends in is the switch's event, which scatters and
    // leaves through the similar stack, not the exact one that B integrates (the walk switches
    // between that event's collision and its scattering: random_walk_loop.h).
    const bool switches_after = settings.similar && !e.similar && e.order + 1 >= settings.similarity_after;
    for (int k = 0; k < light_count; ++k) {
      if (scale[k] == 0.0) continue;
      const ExitDirection& exit = e.similar ? similar_exits[k] : exits[k];
      const bool split = uses_next_flight(e, k);
      // Technique B from this event: the next flight's connection along a direction drawn
      // around the light's inside direction, with its own roulette on depth.
      if (split && e.kind == ScatterEvent::Kind::Volume && !switches_after) {
        double p;
        if (survives_roulette(next_flight_depth_bound(stack_of(e), e, exit) - options_.next_flight_roulette_depth, &p)) {
          const double u1 = rng.uniform(), u2 = rng.uniform();
          lights[k].f_cos += e.throughput * next_flight_connection(stack_of(e), e, exit, u1, u2) * (scale[k] / p);
        }
      }
      double p;
      if (!survives_roulette(exit_optical_depth_bound(stack_of(e), e, exit) - roulette_depth, &p)) continue;
      // The phase roulette (RandomWalkOptions::connection_phase_roulette): below the isotropic
      // value (times the option) a connection is made with probability p_phase / p_ref.
      const ExitDirection::LayerExit& path = exit.layers[e.layer];
      if (phase_ref > 0.0 && lights[k].delta && e.kind == ScatterEvent::Kind::Volume && path.single_lobe) {
        const double q = henyey_greenstein(glm::dot(e.direction, path.inside), path.single_g) / phase_ref;
        if (q < 1.0) {
          if (!(rng.uniform() < q)) continue;
          p *= q;
        }
      }
      // Technique A: this event's own connection, weighted against B when its flight came
      // straight from the previous event (p_A, the density of its direction, is the same for
      // every light).
      double p_a = -1.0;
      if (split && e.flight_from_previous) {
        if (!(p_a_event >= 0.0)) p_a_event = next_flight_direction_pdf(last, e, path.single_g);
        p_a = p_a_event;
      }
      lights[k].f_cos += contribution(e, exit, lights[k], scale[k] / p, p_a);
    }
    LightDirection own;
    if (per_event && per_event->draw(rng, &own)) {
      prepare_exit(stack_of(e), own.wi, &own_exit, settings.guiding, u_interface());
      const double own_scale = light_scale(own, own_exit);
      if (own_scale != 0.0) {
        const Spectrum c = contribution(e, own_exit, own, own_scale);
        if (!c.is_black()) per_event->add(c);
      }
    }
    last = e;
  };
  // The walk's loop with this callback inlined into it (materials/walk/walk_kernel.h).
  const WalkResult walk = walk_detail::run_walk(stack_, wo, rng, on_event, settings, hero_);
  if (events_) *events_ += events;
  if (walk.side == WalkResult::Side::None) return false;  // absorbed or killed by roulette
  next->wi = walk.direction;
  next->weight = walk.weight * entry;
  if (walk.side == WalkResult::Side::Bottom) next->weight *= t_factor;
  next->delta = true;
  next->pdf = 0.0;
  if (walk.straight_from_last_event && !options_.test_hooks.naive) {
    next->delta = false;
    // connections_only: pdf 0 gives such an exit weight 0 on an emitter.
    next->pdf = options_.test_hooks.connections_only ? 0.0 : exit_pdf_for_mis(stack_of(last), last, walk.direction, settings.guiding, walk.top_inside);
  }
  return true;
}

}  // namespace lamina
