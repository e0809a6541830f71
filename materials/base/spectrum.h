// Spectrum: linear RGB (Rec. 709 primaries), three channels, double precision.
// A scalar stands for a grey triple (docs/contracts.md, "Colour").
#pragma once

#include <algorithm>
#include <array>
#include <cmath>

namespace lamina {

constexpr int kChannels = 3;

struct Spectrum {
  std::array<double, kChannels> c{0.0, 0.0, 0.0};

  constexpr Spectrum() = default;
  constexpr explicit Spectrum(double v) : c{v, v, v} {}
  constexpr Spectrum(double r, double g, double b) : c{r, g, b} {}

  double& operator[](int i) { return c[i]; }
  double operator[](int i) const { return c[i]; }

  Spectrum& operator+=(const Spectrum& o) { for (int i = 0; i < kChannels; ++i) c[i] += o.c[i]; return *this; }
  Spectrum& operator-=(const Spectrum& o) { for (int i = 0; i < kChannels; ++i) c[i] -= o.c[i]; return *this; }
  Spectrum& operator*=(const Spectrum& o) { for (int i = 0; i < kChannels; ++i) c[i] *= o.c[i]; return *this; }
  Spectrum& operator*=(double s) { for (double& v : c) v *= s; return *this; }
  Spectrum& operator/=(double s) { for (double& v : c) v /= s; return *this; }

  friend Spectrum operator+(Spectrum a, const Spectrum& b) { return a += b; }
  friend Spectrum operator-(Spectrum a, const Spectrum& b) { return a -= b; }
  friend Spectrum operator*(Spectrum a, const Spectrum& b) { return a *= b; }
  friend Spectrum operator*(Spectrum a, double s) { return a *= s; }
  friend Spectrum operator*(double s, Spectrum a) { return a *= s; }
  friend Spectrum operator/(Spectrum a, double s) { return a /= s; }
  friend Spectrum operator/(Spectrum a, const Spectrum& b) {
    for (int i = 0; i < kChannels; ++i) a.c[i] /= b.c[i];
    return a;
  }
  friend bool operator==(const Spectrum& a, const Spectrum& b) { return a.c == b.c; }

  double max() const { return std::max({c[0], c[1], c[2]}); }
  double min() const { return std::min({c[0], c[1], c[2]}); }
  double average() const { return (c[0] + c[1] + c[2]) / kChannels; }
  bool is_black() const { return c[0] == 0.0 && c[1] == 0.0 && c[2] == 0.0; }
  // The same value in every channel, exactly.
  bool is_grey() const { return c[0] == c[1] && c[1] == c[2]; }
  bool is_finite() const { return std::isfinite(c[0]) && std::isfinite(c[1]) && std::isfinite(c[2]); }
};

inline Spectrum exp(const Spectrum& s) { return {std::exp(s[0]), std::exp(s[1]), std::exp(s[2])}; }

}  // namespace lamina
