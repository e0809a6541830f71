#include "materials/sampling.h"

#include <cmath>

namespace lamina {

std::uint64_t mix64(std::uint64_t x) {
  x += 0x9e3779b97f4a7c15ull;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ull;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebull;
  return x ^ (x >> 31);
}

Rng::Rng(std::uint64_t seed, std::uint64_t a, std::uint64_t b) {
  // Key the state on all three numbers and the stream (increment) on a different mix of them, so
  // neighbouring keys share neither.
  const std::uint64_t key = mix64(mix64(mix64(seed) ^ a) ^ (b * 0xd1342543de82ef95ull));
  state_ = 0;
  inc_ = (mix64(key ^ 0x5851f42d4c957f2dull) << 1u) | 1u;
  next_u32();
  state_ += key;
  next_u32();
}

std::uint32_t Rng::next_u32() {
  const std::uint64_t old = state_;
  state_ = old * 6364136223846793005ull + inc_;
  const auto xorshifted = static_cast<std::uint32_t>(((old >> 18u) ^ old) >> 27u);
  const auto rot = static_cast<std::uint32_t>(old >> 59u);
  return (xorshifted >> rot) | (xorshifted << ((~rot + 1u) & 31u));
}

double Rng::uniform() {
  const std::uint64_t hi = next_u32();
  const std::uint64_t lo = next_u32();
  const std::uint64_t bits = ((hi << 32) | lo) >> 11;  // 53 bits
  return static_cast<double>(bits) * 0x1.0p-53;
}

glm::dvec3 sample_cosine_hemisphere(glm::dvec2 u) {
  const double r = std::sqrt(u.x);
  const double phi = 2.0 * kPi * u.y;
  const double z = std::sqrt(std::max(0.0, 1.0 - u.x));
  return {r * std::cos(phi), r * std::sin(phi), z};
}

glm::dvec3 sample_uniform_sphere(glm::dvec2 u) {
  const double z = 1.0 - 2.0 * u.x;
  const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
  const double phi = 2.0 * kPi * u.y;
  return {r * std::cos(phi), r * std::sin(phi), z};
}

void orthonormal_basis(const glm::dvec3& n, glm::dvec3* t, glm::dvec3* b) {
  const double sign = std::copysign(1.0, n.z);
  const double a = -1.0 / (sign + n.z);
  const double c = n.x * n.y * a;
  *t = {1.0 + sign * n.x * n.x * a, sign * c, -sign * n.x};
  *b = {c, sign + n.y * n.y * a, -n.y};
}

}  // namespace lamina
