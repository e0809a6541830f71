// Environment map: sampler against its pdf (chi-square), pdf/sample consistency, unbiased
// integrals, the map convention, and parsing of `--env`.
#include "renderer/render/environment.h"

#include <cmath>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <vector>

#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include "materials/base/sampling.h"
#include "renderer/image/image_io.h"
#include "tests/support/statistics.h"

namespace fs = std::filesystem;
namespace lamina {
namespace {

std::string temp_path(const std::string& name) {
  return (fs::path(::testing::TempDir()) / ("lamina_env_" + name)).string();
}

// A small map with structure: a gradient, a black pixel, a bright pixel, coloured pixels.
Image synthetic_map(int w, int h) {
  Image image(w, h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      float* p = image.pixel(x, y);
      p[0] = 0.2f + 0.1f * x;
      p[1] = 0.1f + 0.3f * y;
      p[2] = (x + y) % 3 == 0 ? 0.0f : 0.5f;
    }
  float* black = image.pixel(1, 1);
  black[0] = black[1] = black[2] = 0.0f;
  float* bright = image.pixel(w - 2, h / 2);
  bright[0] = 20.0f, bright[1] = 15.0f, bright[2] = 10.0f;
  return image;
}

EnvironmentMap map_from(const Image& image, const std::string& name) {
  const std::string path = temp_path(name + ".exr");
  write_exr(path, image);
  return EnvironmentMap::from_file(path);
}

// The header's convention, written out independently of environment.cpp.
void direction_to_pixel(const glm::dvec3& d, int w, int h, int* x, int* y, double* u, double* v) {
  *u = 0.5 + std::atan2(d.x, -d.z) / (2.0 * kPi);
  *v = std::acos(d.y) / kPi;
  *x = std::min(static_cast<int>(*u * w), w - 1);
  *y = std::min(static_cast<int>(*v * h), h - 1);
}

// Solid angle of the cells [u0,u1] x [v0,v1] of the map: (u1 - u0) 2 pi (cos pi v0 - cos pi v1).
double cell_solid_angle(double u0, double u1, double v0, double v1) {
  return (u1 - u0) * 2.0 * kPi * (std::cos(kPi * v0) - std::cos(kPi * v1));
}

TEST(Environment, SamplerFitsItsPdf) {
  constexpr int W = 8, H = 6, kSub = 2;  // histogram cells: each pixel split 2 x 2
  const EnvironmentMap env = map_from(synthetic_map(W, H), "chi2");
  constexpr int NU = W * kSub, NV = H * kSub;
  constexpr int kSamples = 200000;
  // Expected count of a cell: N times the integral of pdf over it, by a 16 x 16 midpoint rule
  // in (u, v) with d omega = 2 pi^2 sin(theta) du dv.
  std::vector<double> expected(NU * NV, 0.0), observed(NU * NV, 0.0);
  constexpr int kQ = 16;
  for (int j = 0; j < NV; ++j)
    for (int i = 0; i < NU; ++i) {
      double p = 0.0;
      for (int b = 0; b < kQ; ++b)
        for (int a = 0; a < kQ; ++a) {
          const double u = (i + (a + 0.5) / kQ) / NU, v = (j + (b + 0.5) / kQ) / NV;
          const double theta = kPi * v, phi = 2.0 * kPi * (u - 0.5);
          const glm::dvec3 d(std::sin(theta) * std::sin(phi), std::cos(theta), -std::sin(theta) * std::cos(phi));
          p += env.pdf(d) * 2.0 * kPi * kPi * std::sin(theta) / (kQ * kQ * NU * NV);
        }
      expected[j * NU + i] = kSamples * p;
    }
  double total = 0.0;
  for (double e : expected) total += e;
  EXPECT_NEAR(total / kSamples, 1.0, 1e-3);  // the pdf integrates to one over the sphere
  for (int s = 0; s < kSamples; ++s) {
    Rng rng(21, s);
    glm::dvec3 d;
    double pdf;
    env.sample({rng.uniform(), rng.uniform()}, &d, &pdf);
    ASSERT_GT(pdf, 0.0);
    double u, v;
    int x, y;
    direction_to_pixel(d, NU, NV, &x, &y, &u, &v);
    observed[y * NU + x] += 1.0;
  }
  const test::ChiSquareResult chi = test::chi_square_test(observed, expected);
  EXPECT_GT(chi.p_value, 1e-3) << chi.describe();
  // The black pixel (1, 1) is never chosen.
  for (int b = 0; b < kSub; ++b)
    for (int a = 0; a < kSub; ++a) EXPECT_EQ(observed[(kSub + b) * NU + kSub + a], 0.0);
}

TEST(Environment, PixelProbabilityIsLuminanceTimesSolidAngle) {
  constexpr int W = 8, H = 6;
  const Image image = synthetic_map(W, H);
  const EnvironmentMap env = map_from(image, "mass");
  auto lum = [&](int x, int y) {
    const float* p = image.pixel(x, y);
    return 0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2];
  };
  double norm = 0.0;
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) norm += lum(x, y) * cell_solid_angle(double(x) / W, double(x + 1) / W, double(y) / H, double(y + 1) / H);
  // The pdf at a direction in pixel (x, y) times 2 pi^2 sin(theta) is the uv density there,
  // which must be (probability of the pixel) * W * H.
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      const double u = (x + 0.3) / W, v = (y + 0.6) / H;
      const double theta = kPi * v, phi = 2.0 * kPi * (u - 0.5);
      const glm::dvec3 d(std::sin(theta) * std::sin(phi), std::cos(theta), -std::sin(theta) * std::cos(phi));
      const double prob = lum(x, y) * cell_solid_angle(double(x) / W, double(x + 1) / W, double(y) / H, double(y + 1) / H) / norm;
      EXPECT_NEAR(env.pdf(d) * 2.0 * kPi * kPi * std::sin(theta), prob * W * H, 1e-9 * W * H) << x << "," << y;
    }
}

TEST(Environment, SampleAgreesWithPdfAndEval) {
  constexpr int W = 7, H = 5;
  const Image image = synthetic_map(W, H);
  const EnvironmentMap env = map_from(image, "consistency");
  // The bound environment.cpp states: L/pdf <= (1/0.0722) * 2 * 2 pi^2 I, with I the mean of the
  // weights lum * mean_row(sin theta).
  double I = 0.0;
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      const float* p = image.pixel(x, y);
      const double t0 = kPi * y / H, t1 = kPi * (y + 1) / H;
      I += (0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2]) * (std::cos(t0) - std::cos(t1)) / (t1 - t0) / (W * H);
    }
  const double bound = 2.0 * 2.0 * kPi * kPi * I / 0.0722;
  for (int s = 0; s < 20000; ++s) {
    Rng rng(22, s);
    glm::dvec3 d;
    double pdf;
    const Spectrum L = env.sample({rng.uniform(), rng.uniform()}, &d, &pdf);
    ASSERT_NEAR(glm::dot(d, d), 1.0, 1e-12);
    // env.pdf finds the pixel again from d by theta = acos(d.y), whose rounding near the poles
    // moves theta by eps / sin(theta) and the density, proportional to 1 / sin(theta), by the
    // relative eps cos(theta) / sin(theta)^2 (a sample 1e-4 rad from the pole: ~1e-8).
    const double sin2 = d.x * d.x + d.z * d.z;
    const double conditioning = 4.0 * 1.1102230246251565e-16 / std::max(sin2, 1e-300);
    ASSERT_NEAR(env.pdf(d), pdf, (1e-9 + conditioning) * pdf) << s;
    ASSERT_EQ(env.eval(d), L) << s;
    ASSERT_TRUE(L.is_finite());
    ASSERT_LE(L.max() / pdf, bound * (1.0 + 1e-9));
  }
}

// Monte Carlo estimate of integral of L(w) g(w) d w with the environment's own sampler,
// against the exact per-pixel sum; the tolerance is 4 standard errors of the estimate.
TEST(Environment, ImportanceSampledIntegralsMatchExactSums) {
  constexpr int W = 8, H = 6;
  const Image image = synthetic_map(W, H);
  const EnvironmentMap env = map_from(image, "integral");
  // g = 1 (total radiance over the sphere) and g = max(0, cos theta) about +Y (irradiance of an
  // upward-facing plane). Per pixel row [theta0, theta1]:
  //   integral of sin = cos theta0 - cos theta1,
  //   integral of cos sin = (sin^2 theta1 - sin^2 theta0) / 2 (rows above the horizon; H is
  //   even, so no row straddles it).
  Spectrum exact_total, exact_irradiance;
  for (int y = 0; y < H; ++y) {
    const double t0 = kPi * y / H, t1 = kPi * (y + 1) / H;
    const double dphi = 2.0 * kPi / W;
    const double w_total = dphi * (std::cos(t0) - std::cos(t1));
    const double w_irr = y < H / 2 ? dphi * 0.5 * (std::sin(t1) * std::sin(t1) - std::sin(t0) * std::sin(t0)) : 0.0;
    for (int x = 0; x < W; ++x) {
      const float* p = image.pixel(x, y);
      const Spectrum L(p[0], p[1], p[2]);
      exact_total += L * w_total;
      exact_irradiance += L * w_irr;
    }
  }
  constexpr int N = 100000;
  Spectrum sum_t, sum2_t, sum_e, sum2_e;
  for (int s = 0; s < N; ++s) {
    Rng rng(23, s);
    glm::dvec3 d;
    double pdf;
    const Spectrum L = env.sample({rng.uniform(), rng.uniform()}, &d, &pdf);
    const Spectrum t = pdf > 0.0 ? L / pdf : Spectrum();
    const Spectrum e = t * std::max(0.0, d.y);
    sum_t += t, sum2_t += t * t, sum_e += e, sum2_e += e * e;
  }
  for (int c = 0; c < 3; ++c) {
    const double mt = sum_t[c] / N, se_t = std::sqrt((sum2_t[c] / N - mt * mt) / (N - 1));
    const double me = sum_e[c] / N, se_e = std::sqrt((sum2_e[c] / N - me * me) / (N - 1));
    EXPECT_NEAR(mt, exact_total[c], 4.0 * se_t) << "channel " << c;
    EXPECT_NEAR(me, exact_irradiance[c], 4.0 * se_e) << "channel " << c;
    EXPECT_GT(se_t, 0.0);
  }
}

TEST(Environment, ConstantAndBlack) {
  const EnvironmentMap black;
  EXPECT_TRUE(black.is_black());
  glm::dvec3 d;
  double pdf = 1.0;
  EXPECT_TRUE(black.sample({0.3, 0.7}, &d, &pdf).is_black());
  EXPECT_EQ(pdf, 0.0);
  EXPECT_EQ(black.pdf({0, 0, 1}), 0.0);

  const EnvironmentMap grey = EnvironmentMap::constant(Spectrum(0.5, 0.25, 2.0));
  EXPECT_FALSE(grey.is_black());
  // Uniform sphere sampling: L / pdf = 4 pi L for every sample (zero variance).
  for (int s = 0; s < 100; ++s) {
    Rng rng(24, s);
    const Spectrum L = grey.sample({rng.uniform(), rng.uniform()}, &d, &pdf);
    EXPECT_NEAR(pdf, 1.0 / (4.0 * kPi), 1e-15);
    EXPECT_EQ(L, Spectrum(0.5, 0.25, 2.0));
    EXPECT_EQ(grey.eval(-d), L);
  }
  EXPECT_THROW(EnvironmentMap::constant(Spectrum(-1.0)), std::invalid_argument);
}

TEST(Environment, MapCentreLooksDownMinusZAndTopRowUp) {
  constexpr int W = 9, H = 5;
  Image image(W, H);
  image.pixel(4, 2)[0] = image.pixel(4, 2)[1] = image.pixel(4, 2)[2] = 1.0f;  // the centre
  for (int x = 0; x < W; ++x) image.pixel(x, 0)[2] = 0.25f;                  // the top row: blue
  const EnvironmentMap env = map_from(image, "convention");
  EXPECT_EQ(env.eval({0, 0, -1}), Spectrum(1.0));
  EXPECT_EQ(env.eval({0, 0, 1}), Spectrum(0.0));
  EXPECT_EQ(env.eval({0, 1, 0}), Spectrum(0.0, 0.0, 0.25));
  EXPECT_EQ(env.eval({1, 0, 0}), Spectrum(0.0));
  // The centre pixel spans phi in [-20, 20] deg and theta in [72, 108] deg, so its directions
  // have d.z <= -sin(72 deg) cos(20 deg) = -0.894; it holds most of the weight (white against
  // a dim blue cap), and every sample lands in it or in the top row.
  int centre = 0;
  glm::dvec3 mean(0.0);
  for (int s = 0; s < 5000; ++s) {
    Rng rng(25, s);
    glm::dvec3 d;
    double pdf;
    env.sample({rng.uniform(), rng.uniform()}, &d, &pdf);
    if (d.y > std::cos(kPi / H)) continue;  // top row
    ++centre;
    EXPECT_LE(d.z, -std::sin(0.4 * kPi) * std::cos(kPi / W) + 1e-12);
    mean += d;
  }
  ASSERT_GT(centre, 2500);
  mean /= centre;
  EXPECT_LT(mean.z, -0.9);
  EXPECT_NEAR(mean.x, 0.0, 0.05);
  EXPECT_NEAR(mean.y, 0.0, 0.05);
}

TEST(Environment, FromArgument) {
  EXPECT_EQ(EnvironmentMap::from_argument("0.5").eval({0, 1, 0}), Spectrum(0.5));
  EXPECT_EQ(EnvironmentMap::from_argument("0.2,0.3,0.4").eval({1, 0, 0}), Spectrum(0.2, 0.3, 0.4));
  EXPECT_TRUE(EnvironmentMap::from_argument("0").is_black());
  const std::string path = temp_path("argument.exr");
  write_exr(path, synthetic_map(4, 2));
  EXPECT_FALSE(EnvironmentMap::from_argument(path).is_black());
  // 1e300 and 1e21 are finite doubles, but beyond the largest light strength (1e20): they
  // wrote Inf pixels.
  EXPECT_EQ(EnvironmentMap::from_argument("1e20").eval({0, 1, 0}), Spectrum(1e20));
  for (const std::string bad : {"", "nan", "-1", "0.2,0.3", "1,2,3,4", "0.2,abc,0.3", "inf", "0.1,-0.2,0.3",
                                "no_such_file.exr", "0.5x", "1e300", "0.1,1e21,0.1"}) {
    try {
      EnvironmentMap::from_argument(bad);
      ADD_FAILURE() << "accepted '" << bad << "'";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find("'" + bad + "'"), std::string::npos) << e.what();
    }
  }
}

TEST(Environment, BadMapFilesNameTheFile) {
  Image image = synthetic_map(4, 2);
  image.pixel(2, 1)[1] = std::nanf("");
  const std::string nan_path = temp_path("nan.exr");
  write_exr(nan_path, image);
  try {
    EnvironmentMap::from_file(nan_path);
    ADD_FAILURE() << "accepted a NaN pixel";
  } catch (const ImageIoError& e) {
    EXPECT_NE(std::string(e.what()).find(nan_path), std::string::npos) << e.what();
  }
  EXPECT_THROW(EnvironmentMap::from_file(temp_path("missing.exr")), ImageIoError);
  image = synthetic_map(4, 2);
  image.pixel(3, 0)[2] = 3e38f;  // finite in float, beyond the largest light strength
  const std::string bright_path = temp_path("bright.exr");
  write_exr(bright_path, image);
  try {
    EnvironmentMap::from_file(bright_path);
    ADD_FAILURE() << "accepted a pixel of 3e38";
  } catch (const ImageIoError& e) {
    EXPECT_NE(std::string(e.what()).find(bright_path + "': pixel (3, 0) is above the largest light strength"),
              std::string::npos)
        << e.what();
  }
}

}  // namespace
}  // namespace lamina
