#include "materials/walk/next_flight_connection.h"

#include <cmath>
#include <limits>

#include <glm/geometric.hpp>

#include "materials/phase/henyey_greenstein.h"

namespace lamina {

namespace {

// integral_0^len exp(-c s) ds times exp(-offset), without overflow for c < 0:
// for c < 0 it is exp(-offset - c len) integral_0^len exp(c u) du (u = len - s), and
// -offset - c len is the exponent at the far end of the flight.
double attenuated_path_integral(double c, double len, double offset) {
  if (len == std::numeric_limits<double>::infinity()) return c > 0.0 ? std::exp(-offset) / c : 0.0;
  const double x = std::abs(c) * len;
  // (1 - exp(-x)) / x, exact to rounding near x = 0.
  const double phi = x < 1e-8 ? 1.0 - 0.5 * x : -std::expm1(-x) / x;
  const double exponent = c >= 0.0 ? -offset : -offset - c * len;
  return std::exp(exponent) * len * phi;
}

}  // namespace

bool next_flight_layer(int layer, const ExitDirection& exit, double min_g) {
  if (exit.layers.empty()) return false;
  const ExitDirection::LayerExit& path = exit.layers[layer];
  if (!path.exists || !path.single_lobe || path.single_g < min_g) return false;
  if (!exit.guided.empty() && exit.guided[layer].guiding > 0.0) return false;
  for (int c = 0; c < kChannels; ++c)
    if (!(path.sigma_s[c] > 0.0)) return false;
  return true;
}

double next_flight_direction_pdf(const ScatterEvent& previous, const ScatterEvent& event, double g) {
  return henyey_greenstein(glm::dot(previous.direction, event.direction), g);
}

double next_flight_weight_of_event(const ScatterEvent& previous, const ScatterEvent& event,
                                   const ExitDirection& exit) {
  const ExitDirection::LayerExit& path = exit.layers[event.layer];
  return next_flight_weight(next_flight_direction_pdf(previous, event, path.single_g),
                            henyey_greenstein(glm::dot(event.direction, path.inside), path.single_g));
}

Spectrum next_flight_connection(const LayerStack& stack, const ScatterEvent& event,
                                const ExitDirection& exit, double u1, double u2) {
  const ExitDirection::LayerExit& path = exit.layers[event.layer];
  const Layer& layer = stack.layers[event.layer];
  const double g = path.single_g;
  // Technique B's direction: the phase function around b, i.e. density p(d . b).
  const glm::dvec3 d = sample_henyey_greenstein(path.inside, g, u1, u2);
  const double p_a = henyey_greenstein(glm::dot(event.direction, d), g);
  const double p_b = henyey_greenstein(glm::dot(d, path.inside), g);
  if (!(p_a > 0.0 && p_b > 0.0)) return Spectrum(0.0);
  // The flight to the layer's boundary and the distance to the exit side along it.
  constexpr double kInf = std::numeric_limits<double>::infinity();
  const double s_max = d.z < 0.0 ? (layer.semi_infinite() ? kInf : (layer.thickness - event.depth) / -d.z)
                       : d.z > 0.0 ? event.depth / d.z
                                   : kInf;
  const double distance0 = distance_to_exit_side(stack, event, exit);
  const double distance_rate = exit.up ? -d.z : d.z;  // d(distance to the exit side) / ds
  // W p_A p_B / (p_A + p_B) G(d_B) / p_B: the p_B of G cancels the 1/p_B of the sample.
  const double mis = next_flight_weight(p_a, p_b);
  const double emission = p_b / path.mu_inside;  // p(d . b) / mu_b, as connect_direct
  const Spectrum& sigma_t = path.sigma_t;
  const Spectrum& sigma_s = path.sigma_s;
  Spectrum out;
  for (int c = 0; c < kChannels; ++c) {
    const double r = path.depth_rate[c];
    const double integral =
        attenuated_path_integral(sigma_t[c] + r * distance_rate, s_max, path.tau_beyond[c] + r * distance0);
    out[c] = mis * emission * path.radiance_scale * sigma_s[c] * integral;
  }
  return out;
}

Spectrum next_flight_event_connection(const LayerStack& stack, const ScatterEvent& previous,
                                      const ScatterEvent& event, const ExitDirection& exit, double u1,
                                      double u2) {
  Spectrum own = connect_direct(stack, event, exit).weight;
  if (!next_flight_layer(event.layer, exit)) return event.throughput * own;
  if (event.flight_from_previous) own *= next_flight_weight_of_event(previous, event, exit);
  if (event.kind == ScatterEvent::Kind::Volume) own += next_flight_connection(stack, event, exit, u1, u2);
  return event.throughput * own;
}


}  // namespace lamina
