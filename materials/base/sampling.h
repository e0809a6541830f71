// Random numbers and warps.
//
// A random stream is a pure function of (seed, stream index): the renderer uses one stream per
// (pixel, sample), the BRDF tool one per photon, so results never depend on threads or
// scheduling (docs/architecture.md, "Rules of thumb").
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

namespace lamina {

// SplitMix64 finaliser (Steele, Lea and Flood, "Fast splittable pseudorandom number generators",
// OOPSLA 2014): a bijective 64-bit mixer used to derive independent stream states.
// Inline (as is the generator below): the renderer draws several numbers per ray and makes one
// generator per (pixel, sample), so a call per number was a measurable share of the render loop.
inline std::uint64_t mix64(std::uint64_t x) {
  x += 0x9e3779b97f4a7c15ull;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ull;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebull;
  return x ^ (x >> 31);
}

// A PCG generator (O'Neill, "PCG: A family of simple fast space-efficient statistically good
// algorithms for random number generation", 2014): a 64-bit linear congruential state with a
// selectable stream (the increment), and the RXS M XS output permutation of the whole 64-bit
// state (the paper's section 6.3.4; pcg64_once_insecure in its C library): one step per
// uniform. (The first generator, PCG32, took two 32-bit steps per 53-bit uniform, and the
// random numbers were a tenth of a walk's instructions.) The output is a bijection of the state,
// so a stream repeats no value within its period of 2^64 steps, far beyond any walk.
class Rng {
 public:
  // The stream for (seed, a, b): e.g. (seed, pixel, sample) in the renderer, (seed, photon, 0)
  // in the BRDF tool. Distinct keys give statistically independent sequences.
  Rng(std::uint64_t seed, std::uint64_t a, std::uint64_t b = 0) {
    // Key the state on all three numbers and the stream (increment) on a different mix of
    // them, so neighbouring keys share neither.
    const std::uint64_t key = mix64(mix64(mix64(seed) ^ a) ^ (b * 0xd1342543de82ef95ull));
    state_ = 0;
    inc_ = (mix64(key ^ 0x5851f42d4c957f2dull) << 1u) | 1u;
    next_u64();
    state_ += key;
    next_u64();
  }

  std::uint64_t next_u64() {
    const std::uint64_t old = state_;
    state_ = old * 6364136223846793005ull + inc_;
    const std::uint64_t word = ((old >> ((old >> 59u) + 5u)) ^ old) * 12605985483714917081ull;
    return (word >> 43u) ^ word;
  }
  // Uniform in [0, 1): 53 random bits, so never exactly 1 and fine enough for -log(u) tails.
  double uniform() { return static_cast<double>(next_u64() >> 11) * 0x1.0p-53; }
  // Uniform in (0, 1]: safe as the argument of log().
  double uniform_open0() { return 1.0 - uniform(); }

 private:
  std::uint64_t state_;
  std::uint64_t inc_;
};

constexpr double kPi = 3.14159265358979323846;
constexpr double kInvPi = 1.0 / kPi;
constexpr double kInv4Pi = 1.0 / (4.0 * kPi);

// (cos 2 pi u, sin 2 pi u) for u in [0, 1]: the azimuth of a uniformly sampled direction.
// Every scattering event of a walk draws one, and the library's sincos, which reduces any
// argument, was 7-8 % of a render's time. Here the reduction is exact: u = k/4 + r with
// |r| <= 1/8 (u - k/4 is representable: Sterbenz), x = 2 pi r in [-pi/4, pi/4], then the Taylor
// polynomials to x^15 and x^16, whose first omitted terms are below 5e-17 there (|x|^17/17!,
// |x|^18/18!), and the quarter turns k map (cos x, sin x) to the quadrant.
// Evaluation order: a Horner chain of eight multiply-subtract steps is a long dependency chain;
// here the small high-order terms go by Estrin's scheme in y = x^2 (independent pairs combined
// by powers of y) and only the two leading steps, where the rounding to 1 happens, are
// Horner's: the rounding of every earlier step is scaled down by y / 6 or y / 2. (A sampling
// profile put 13 % of a render on the Horner loop; the measured gain was 1 %: the azimuth does
// not depend on the old direction, so the processor overlaps it with other work.)
inline glm::dvec2 unit_circle(double u) {
  const double k = static_cast<double>(static_cast<long long>(4.0 * u + 0.5));  // nearest, u >= 0
  const double x = 2.0 * kPi * (u - 0.25 * k);
  const double y = x * x, y2 = y * y, y4 = y2 * y2;
  // sin x / x = 1 - y (1/3! - y Q(y)), Q = 1/5! - y/7! + y^2/9! - y^3/11! + y^4/13! - y^5/15!
  const double q = (1.0 / 120.0 - y * (1.0 / 5040.0)) + y2 * (1.0 / 362880.0 - y * (1.0 / 39916800.0)) +
                   y4 * (1.0 / 6227020800.0 - y * (1.0 / 1307674368000.0));
  // cos x = 1 - y (1/2! - y P(y)), P = 1/4! - y/6! + y^2/8! - y^3/10! + y^4/12! - y^5/14! + y^6/16!
  const double p = (1.0 / 24.0 - y * (1.0 / 720.0)) + y2 * (1.0 / 40320.0 - y * (1.0 / 3628800.0)) +
                   y4 * ((1.0 / 479001600.0 - y * (1.0 / 87178291200.0)) + y2 * (1.0 / 20922789888000.0));
  const double s = x * (1.0 - y * (1.0 / 6.0 - y * q));
  const double c = 1.0 - y * (0.5 - y * p);
  // The quarter turn k (mod 4) maps (c, s) to (c, s), (-s, c), (-c, -s), (s, -c). Without a
  // branch: the quadrant is random, so a switch on it was mispredicted three times in four.
  const int turn = static_cast<int>(k) & 3;
  const double pair[2] = {c, s};
  constexpr double kSignX[4] = {1.0, -1.0, -1.0, 1.0}, kSignY[4] = {1.0, 1.0, -1.0, -1.0};
  return {kSignX[turn] * pair[turn & 1], kSignY[turn] * pair[1 - (turn & 1)]};
}

// An exponential variate of mean 1 (a free flight's optical depth), by the ziggurat method
// (Marsaglia and Tsang, "The Ziggurat Method for Generating Random Variables", J. Stat. Softw.
// 5(8), 2000). The area under exp(-x) is cut into 256 pieces of equal area v: a base strip of
// height exp(-r) (the rectangle [0, r] and the tail beyond r; with the tail it has the virtual
// width r + 1) and 255 horizontal strips [0, x_i] x [exp(-x_i), exp(-x_(i+1))], x_1 = r, the
// last ending at height 1. A strip chosen uniformly and a point x uniform along its width lies
// under the curve for sure where x < x_(i+1) (99 % of draws: one generator step, a table lookup
// and a multiplication); else the tail (memoryless: r + an exponential) or a test of a uniform
// height against exp(-x) in the strip's wedge, and a rejected point starts again. Exact, like
// -log(u), which cost a logarithm (about 50 instructions) per flight.
struct ExponentialZiggurat {
  double x[257];  // x[0] = r + 1 (the base strip's width with its tail), x[1] = r, ..., x[256] = 0
  double y[257];  // exp(-x[i]) for i >= 1 (y[256] = 1)
};
extern const ExponentialZiggurat kExponentialZiggurat;
// The draws past the fast path: strip i, x >= x_(i+1). Returns a variate, or -1 (rejected).
double exponential_ziggurat_edge(Rng& rng, int strip, double x);
inline double sample_exponential(Rng& rng) {
  const ExponentialZiggurat& z = kExponentialZiggurat;
  for (;;) {
    const std::uint64_t bits = rng.next_u64();
    const int strip = static_cast<int>(bits & 255u);  // bits 0-7; the position takes bits 11-63
    const double x = static_cast<double>(bits >> 11) * 0x1.0p-53 * z.x[strip];
    if (x < z.x[strip + 1]) return x;
    const double edge = exponential_ziggurat_edge(rng, strip, x);
    if (edge >= 0.0) return edge;
  }
}

// Cosine-weighted hemisphere about +z (Malley's method); pdf = cos(theta)/pi.
glm::dvec3 sample_cosine_hemisphere(glm::dvec2 u);
// Uniform sphere; pdf = 1/(4 pi).
inline glm::dvec3 sample_uniform_sphere(glm::dvec2 u) {
  const double z = 1.0 - 2.0 * u.x;
  const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
  const glm::dvec2 azimuth = unit_circle(u.y);
  return {r * azimuth.x, r * azimuth.y, z};
}

// An orthonormal basis (t, b, n) around the unit vector n, continuous except on a set of
// measure zero and exact at n = +-z (Duff et al., "Building an Orthonormal Basis, Revisited",
// JCGT 2017). Replaces the slides' direction update, which divides by sin(theta) and fails
// when the direction is along the normal.
// Inline: every scattering event of a walk builds one.
inline void orthonormal_basis(const glm::dvec3& n, glm::dvec3* t, glm::dvec3* b) {
  const double sign = std::copysign(1.0, n.z);
  const double a = -1.0 / (sign + n.z);
  const double c = n.x * n.y * a;
  *t = {1.0 + sign * n.x * n.x * a, sign * c, -sign * n.x};
  *b = {c, sign + n.y * n.y * a, -n.y};
}

}  // namespace lamina
