// Where the variance of one random walk's light connections comes from (a
// decomposition). For a stack, a viewing direction wo and a delta light direction wl, each walk
// gives X = sum_e W_e connection_weight(e, wl) (what the renderer adds per walk for a delta
// light, up to Li cos / (1 - R)). Prints, per channel and for luminance, the mean, the relative
// standard deviation of one walk, the events per walk and the equal-error cost (events x
// relative variance), for the stack as given and for variants that remove one source of
// variance each:
//   hero fixed k   : the walk's hero is channel k (spectral MIS switched off for that channel)
//   grey <c>       : every channel given channel c's coefficients (no spectral weights at all)
//   similarity     : g -> 0 with sigma_s (1 - g) in every layer (the phase-function factor gone;
//                    a different, approximate medium: its mean is shown for comparison)
//   next-flight MIS: the connections of materials/walk/next_flight_connection.h (the renderer's default
//                    for delta lights)
//   + render roulette: and the renderer's walk roulette (renderer_walk_options(): below half
//                    the entering weight, survival 1/2)
//   similarity >N  : the walk's option WalkOptions::similarity_after = N (exact first N events)
//   guided q       : WalkOptions::guiding = q (it acts only in isotropic layers: none in skin)
//   sim.+guided q  : the similarity-transformed stack (isotropic) with guiding q
// and the share of the mean and of the second moment by event order.
//   walk_variance STACK.json [walks] [wo_deg] [wl_deg] [quick]   (quick: the first three rows only)
// Not run by the test suite.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "materials/walk/next_flight_connection.h"
#include "materials/walk/random_walk.h"
#include "materials/stack/stack_file.h"
#include "renderer/surfaces/random_walk_surface.h"
#include "materials/interfaces/microsurface.h"

using namespace lamina;

namespace {

double luminance(const Spectrum& s) { return 0.2126 * s[0] + 0.7152 * s[1] + 0.0722 * s[2]; }

struct Stats {
  double sum[4] = {0, 0, 0, 0}, sum2[4] = {0, 0, 0, 0};
  double events = 0;
  double order_mean[4] = {0, 0, 0, 0};  // luminance by order bucket: 1, 2-9, 10-49, 50+
  double order_m2[4] = {0, 0, 0, 0};
  long n = 0;
};

int bucket(int order) { return order <= 1 ? 0 : order < 10 ? 1 : order < 50 ? 2 : 3; }

Stats run(const LayerStack& stack, const glm::dvec3& wo, const glm::dvec3& wl, long walks, int hero,
          const WalkOptions& settings = {}, bool next_flight = false) {
  Stats st;
  // Through energy-conserving rough interfaces the way out is sampled: once per walk, as the
  // renderer does.
  const bool sampled_exit = stack.energy_conserving_rough();
  ExitDirection exit = prepare_exit(stack, wl, settings.guiding), similar_exit;
  if (settings.similar) similar_exit = prepare_exit(*settings.similar, wl, settings.guiding);
  for (long i = 0; i < walks; ++i) {
    Rng rng(1234, static_cast<std::uint64_t>(i), 7);
    Rng rng_b(4321, static_cast<std::uint64_t>(i), 9);
    if (sampled_exit) {
      prepare_exit(stack, wl, &exit, settings.guiding, {0.5, 0.5}, &rng_b);
      if (settings.similar) prepare_exit(*settings.similar, wl, &similar_exit, settings.guiding, {0.5, 0.5}, &rng_b);
    }
    Spectrum x(0.0);
    double by_bucket[4] = {0, 0, 0, 0};
    long events = 0;
    ScatterEvent previous;
    random_walk(stack, wo, rng, [&](const ScatterEvent& e) {
      ++events;
      const LayerStack& s = stack_of_event(stack, settings, e);
      const double u1 = rng_b.uniform(), u2 = rng_b.uniform();
      const Spectrum c = next_flight && !e.similar ? next_flight_event_connection(s, previous, e, exit, u1, u2)
                                                   : e.throughput * connect_direct(s, e, e.similar ? similar_exit : exit).weight;
      previous = e;
      x += c;
      by_bucket[bucket(e.order)] += luminance(c);
    }, settings, hero);
    for (int c = 0; c < 3; ++c) {
      st.sum[c] += x[c];
      st.sum2[c] += x[c] * x[c];
    }
    const double y = luminance(x);
    st.sum[3] += y;
    st.sum2[3] += y * y;
    for (int b = 0; b < 4; ++b) {
      st.order_mean[b] += by_bucket[b];
      st.order_m2[b] += by_bucket[b] * by_bucket[b];
    }
    st.events += events;
    ++st.n;
  }
  return st;
}

void print(const char* label, const Stats& st) {
  const double n = static_cast<double>(st.n);
  std::printf("%-16s events/walk %7.1f |", label, st.events / n);
  for (int c = 0; c < 4; ++c) {
    const double m = st.sum[c] / n, v = st.sum2[c] / n - m * m;
    std::printf(" %s %.4g (rsd %5.2f)", c == 3 ? "Y" : c == 0 ? "R" : c == 1 ? "G" : "B", m, std::sqrt(v) / m);
  }
  const double my = st.sum[3] / n, vy = st.sum2[3] / n - my * my;
  std::printf(" | cost(Y) %.1f\n", st.events / n * vy / (my * my));
  std::printf("%-16s   by order (share of mean Y / of second moment): ", "");
  double m2 = 0;
  for (int b = 0; b < 4; ++b) m2 += st.order_m2[b];
  const char* names[4] = {"1", "2-9", "10-49", "50+"};
  for (int b = 0; b < 4; ++b)
    std::printf(" %s: %.2f/%.2f", names[b], st.order_mean[b] / st.sum[3], st.order_m2[b] / m2);
  std::printf("\n");
}

LayerStack grey(LayerStack s, int channel) {
  for (Layer& l : s.layers) {
    l.sigma_a = Spectrum(l.sigma_a[channel]);
    for (PhaseLobe& p : l.lobes) {
      p.sigma_s = Spectrum(p.sigma_s[channel]);
      p.g = Spectrum(p.g[channel]);
    }
  }
  if (s.below.kind == Below::Kind::Lambert) s.below.albedo = Spectrum(s.below.albedo[channel]);
  return s;
}

LayerStack similarity(LayerStack s) {
  for (Layer& l : s.layers)
    for (PhaseLobe& p : l.lobes) {
      for (int c = 0; c < 3; ++c) p.sigma_s[c] *= 1.0 - p.g[c];
      p.g = Spectrum(0.0);
    }
  return s;
}


// Energy-conserving rough interfaces: where the variance of the renderer's estimate at one hit
// comes from. "surface": RandomWalkSurface::scatter towards one delta light (its f_cos: the top's
// glossy lobe plus the walk's connections), timed; "glossy": the top's lobe alone
// (MicrosurfaceDielectric::eval, one estimate); "crossing xK": the walk's connections with the
// way out through the rough interfaces sampled K times per walk and averaged (K = 1 is what the
// renderer does: one microsurface walk per light direction, shared by all the walk's events);
// "per event": a fresh crossing for every event.
struct Timed {
  Stats st;
  double seconds = 0.0;
};

void print_timed(const char* label, const Timed& t) {
  const double n = static_cast<double>(t.st.n);
  const double my = t.st.sum[3] / n, vy = t.st.sum2[3] / n - my * my;
  std::printf("%-18s Y %.5g +- %.2g  rsd %6.3f  us/walk %7.2f  cost(Y) x1e6 %8.3f  rsd RGB", label, my,
              std::sqrt(vy / n), std::sqrt(vy) / my, 1e6 * t.seconds / n, t.seconds / n * vy / (my * my) * 1e6);
  for (int c = 0; c < 3; ++c) {
    const double m = t.st.sum[c] / n, v = t.st.sum2[c] / n - m * m;
    std::printf(" %.3f", std::sqrt(std::max(0.0, v)) / m);
  }
  std::printf("\n");
}

void add(Stats* st, const Spectrum& x) {
  for (int c = 0; c < 3; ++c) {
    st->sum[c] += x[c];
    st->sum2[c] += x[c] * x[c];
  }
  const double y = luminance(x);
  st->sum[3] += y;
  st->sum2[3] += y * y;
  ++st->n;
}

// copies > 1: the light given that many times (each crossing the rough top by its own sample),
// the estimates averaged.
Timed run_surface(const LayerStack& stack, const glm::dvec3& wo, const glm::dvec3& wl, long walks,
                  const RandomWalkOptions& options, int copies = 1) {
  Timed t;
  const RandomWalkSurface surface(stack, kRandomHero, options);
  std::vector<LightDirection> lights(copies);
  const auto start = std::chrono::steady_clock::now();
  for (long i = 0; i < walks; ++i) {
    Rng rng(1234, static_cast<std::uint64_t>(i), 11);
    for (LightDirection& light : lights) {
      light.wi = wl;
      light.delta = true;
    }
    SurfaceScatter next;
    surface.scatter(wo, rng, lights.data(), copies, nullptr, &next);
    Spectrum sum(0.0);
    for (const LightDirection& light : lights) sum += light.f_cos;
    add(&t.st, sum / static_cast<double>(copies));
  }
  t.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return t;
}

// A white sky (radiance 1 from every direction above): one light sample uniform on the
// hemisphere (MIS with the surface's continuation, as the integrator weights an emitter it hits),
// plus the continuation if it leaves upwards. The reflected radiance, whose mean is the albedo.
Timed run_sky(const LayerStack& stack, const glm::dvec3& wo, long walks) {
  Timed t;
  const RandomWalkSurface surface(stack, kRandomHero, RandomWalkOptions{});
  const double pdf = 1.0 / (2.0 * M_PI);
  const auto start = std::chrono::steady_clock::now();
  for (long i = 0; i < walks; ++i) {
    Rng rng(1234, static_cast<std::uint64_t>(i), 19);
    LightDirection light;
    const double z = rng.uniform();
    const glm::dvec2 phi = unit_circle(rng.uniform());
    const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
    light.wi = {r * phi.x, r * phi.y, z};
    light.pdf = pdf;
    SurfaceScatter next;
    Spectrum x(0.0);
    const bool continues = surface.scatter(wo, rng, &light, 1, nullptr, &next);
    x += light.f_cos / pdf;
    if (continues && next.wi.z > 0.0) x += next.weight * (next.delta ? 1.0 : power_heuristic(next.pdf, pdf));
    add(&t.st, x);
  }
  t.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return t;
}

Timed run_glossy(const LayerStack& stack, const glm::dvec3& wo, const glm::dvec3& wl, long walks) {
  Timed t;
  const MicrosurfaceDielectric top{{stack.energy_conserving_alpha(0)}, stack.above_ior, stack.layers[0].ior};
  const auto start = std::chrono::steady_clock::now();
  for (long i = 0; i < walks; ++i) {
    Rng rng(1234, static_cast<std::uint64_t>(i), 13);
    add(&t.st, Spectrum(top.eval(wo, wl, rng) * wl.z));
  }
  t.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return t;
}

// crossings > 0: that many exits per walk, averaged; 0: a fresh exit per event.
Timed run_crossings(const LayerStack& stack, const glm::dvec3& wo, const glm::dvec3& wl, long walks, int crossings) {
  Timed t;
  std::vector<ExitDirection> exits(std::max(crossings, 1));
  const auto start = std::chrono::steady_clock::now();
  for (long i = 0; i < walks; ++i) {
    Rng rng(1234, static_cast<std::uint64_t>(i), 7);
    Rng rng_x(4321, static_cast<std::uint64_t>(i), 17);
    for (int k = 0; k < crossings; ++k) prepare_exit(stack, wl, &exits[k], 0.0, {0.5, 0.5}, &rng_x);

    Spectrum x(0.0);
    random_walk(stack, wo, rng, [&](const ScatterEvent& e) {
      if (crossings == 0) {
        prepare_exit(stack, wl, &exits[0], 0.0, {0.5, 0.5}, &rng_x);
        x += e.throughput * connect_direct(stack, e, exits[0]).weight;
        return;
      }
      Spectrum sum(0.0);
      for (int k = 0; k < crossings; ++k) sum += connect_direct(stack, e, exits[k]).weight;
      x += e.throughput * sum / static_cast<double>(crossings);
    });
    add(&t.st, x * wl.z);
  }
  t.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return t;
}

void rough_crossing_section(const LayerStack& stack, const glm::dvec3& wo, const glm::dvec3& wl, long walks,
                            bool quick) {
  std::printf("-- energy-conserving rough interfaces: one hit, one delta light (f cos)\n");
  print_timed("surface", run_surface(stack, wo, wl, walks, RandomWalkOptions{}));
  if (stack.energy_conserving_alpha(0) > 0.0) print_timed("glossy", run_glossy(stack, wo, wl, walks));
  print_timed("sky", run_sky(stack, wo, walks));
  if (quick) return;
  print_timed("surface x4 light", run_surface(stack, wo, wl, walks, RandomWalkOptions{}, 4));
  print_timed("surface x16 light", run_surface(stack, wo, wl, walks, RandomWalkOptions{}, 16));
  for (int k : {1, 2, 4, 16, 64}) {
    char label[32];
    std::snprintf(label, sizeof label, "crossing x%d", k);
    print_timed(label, run_crossings(stack, wo, wl, walks, k));
  }
  print_timed("crossing per event", run_crossings(stack, wo, wl, walks, 0));
  LayerStack single = stack;
  single.interface_model = InterfaceModel::SingleScattering;
  print_timed("single-scat. top", run_surface(single, wo, wl, walks, RandomWalkOptions{}));
  print_timed("sky, single-scat.", run_sky(single, wo, walks));
  LayerStack smooth = stack;
  smooth.top_roughness = 0.0;
  print_timed("smooth top", run_surface(smooth, wo, wl, walks, RandomWalkOptions{}));
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: walk_variance STACK.json [walks] [wo_deg] [wl_deg]\n");
    return 2;
  }
  const LayerStack stack = load_stack_file(argv[1]);
  const long walks = argc > 2 ? std::atol(argv[2]) : 20000;
  const double a = (argc > 3 ? std::atof(argv[3]) : 20.0) * M_PI / 180.0;
  const double b = (argc > 4 ? std::atof(argv[4]) : 40.0) * M_PI / 180.0;
  const glm::dvec3 wo{std::sin(a), 0.0, std::cos(a)}, wl{-std::sin(b), 0.0, std::cos(b)};
  if (stack.energy_conserving_rough()) rough_crossing_section(stack, wo, wl, walks, argc > 5);
  print("as given", run(stack, wo, wl, walks, kRandomHero));
  print("next-flight MIS", run(stack, wo, wl, walks, kRandomHero, {}, true));
  WalkOptions render_roulette;  // the renderer's walk roulette
  render_roulette.roulette_threshold = renderer_walk_options().roulette_threshold;
  render_roulette.roulette_survival = renderer_walk_options().roulette_survival;
  print("+ render roulette", run(stack, wo, wl, walks, kRandomHero, render_roulette, true));
  if (argc > 5) return 0;  // quick: the three above only
  for (int k = 0; k < 3; ++k) {
    char label[32];
    std::snprintf(label, sizeof label, "hero fixed %d", k);
    print(label, run(stack, wo, wl, walks, k));
  }
  for (int k = 0; k < 3; ++k) {
    char label[32];
    std::snprintf(label, sizeof label, "grey %c", "RGB"[k]);
    print(label, run(grey(stack, k), wo, wl, walks, kRandomHero));
  }
  print("similarity", run(similarity(stack), wo, wl, walks, kRandomHero));
  for (double q : {0.25, 0.5, 0.75}) {
    WalkOptions ws;
    ws.guiding = q;
    char label[32];
    std::snprintf(label, sizeof label, "guided %.2f", q);
    print(label, run(stack, wo, wl, walks, kRandomHero, ws));
    std::snprintf(label, sizeof label, "sim.+guided %.2f", q);
    print(label, run(similarity(stack), wo, wl, walks, kRandomHero, ws));
  }
  const LayerStack similar = similarity(stack);
  for (int after : {3, 9, 20}) {
    WalkOptions ws;
    ws.similarity_after = after;
    ws.similar = &similar;
    char label[32];
    std::snprintf(label, sizeof label, "similarity >%d", after);
    print(label, run(stack, wo, wl, walks, kRandomHero, ws));
  }
  return 0;
}
