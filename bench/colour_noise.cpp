// Luminance and chroma noise of a render, measured over independent seeds (and optionally against
// a high-spp reference). Used to measure the stratified hero channel of the layered random walk
// (docs/random_walk.md, "Spectral MIS"); not run by the test suite.
//
//   colour_noise [--ref REF.exr] A.exr B.exr C.exr ...   (the same render with different seeds)
//
// Per pixel we split the colour into a luminance Y = 0.2126 R + 0.7152 G + 0.0722 B (Rec. 709)
// and two opponent differences R - G and B - G (zero for any grey change, so they carry what the
// hero-channel sampling does to the colour and little of the luminance noise). For each of the
// three, the seed noise is sqrt(mean over pixels of the unbiased sample variance across the K
// images), i.e. the per-pixel standard deviation of one render, with no reference noise in it.
// With --ref, also the RMSE of every image against the reference (includes the reference's own
// noise, smaller by its spp ratio). Everything is divided by the mean Y over the measured pixels,
// so the numbers are relative. Measured pixels: those whose mean Y over the seeds is above 1 % of
// the image's mean Y (drops the black background, whose zero noise would dilute the means).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "renderer/image/image.h"
#include "renderer/image/image_io.h"

namespace {

struct Opponent {
  double y, rg, bg;
};

Opponent opponent(const float* p) {
  return {0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2], double(p[0]) - p[1], double(p[2]) - p[1]};
}

}  // namespace

int main(int argc, char** argv) {
  std::string ref_path;
  std::vector<std::string> paths;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--ref" && i + 1 < argc) ref_path = argv[++i];
    else paths.push_back(a);
  }
  if (paths.size() < 2) {
    std::fprintf(stderr, "colour_noise: need at least two images of different seeds\n");
    return 2;
  }
  try {
    std::vector<lamina::Image> images;
    for (const std::string& p : paths) images.push_back(lamina::read_image(p));
    const int w = images[0].width, h = images[0].height;
    for (std::size_t k = 0; k < images.size(); ++k)
      if (images[k].width != w || images[k].height != h) {
        std::fprintf(stderr, "colour_noise: %s: size differs from %s\n", paths[k].c_str(), paths[0].c_str());
        return 2;
      }
    lamina::Image ref;
    if (!ref_path.empty()) {
      ref = lamina::read_image(ref_path);
      if (ref.width != w || ref.height != h) {
        std::fprintf(stderr, "colour_noise: %s: size differs from the images\n", ref_path.c_str());
        return 2;
      }
    }
    const double K = static_cast<double>(images.size());
    // Mean Y per pixel over the seeds, and the image mean (for the mask).
    std::vector<double> mean_y(static_cast<std::size_t>(w) * h, 0.0);
    double image_mean = 0.0;
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        double s = 0.0;
        for (const auto& im : images) s += opponent(im.pixel(x, y)).y;
        mean_y[static_cast<std::size_t>(y) * w + x] = s / K;
        image_mean += s / K;
      }
    image_mean /= static_cast<double>(w) * h;
    // var: sum over pixels of the per-pixel variance estimates; var2: of their squares (for the
    // standard error of the mean variance, pixels being independent).
    double var[3] = {0, 0, 0}, var2[3] = {0, 0, 0}, se2[3] = {0, 0, 0}, sum_y = 0.0;
    long n = 0;
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        const double my = mean_y[static_cast<std::size_t>(y) * w + x];
        if (!(my > 0.01 * image_mean)) continue;
        ++n;
        sum_y += my;
        Opponent m{0, 0, 0};
        for (const auto& im : images) {
          const Opponent o = opponent(im.pixel(x, y));
          m.y += o.y / K;
          m.rg += o.rg / K;
          m.bg += o.bg / K;
        }
        Opponent r{0, 0, 0};
        if (!ref_path.empty()) r = opponent(ref.pixel(x, y));
        double v[3] = {0, 0, 0};
        for (const auto& im : images) {
          const Opponent o = opponent(im.pixel(x, y));
          v[0] += (o.y - m.y) * (o.y - m.y) / (K - 1.0);
          v[1] += (o.rg - m.rg) * (o.rg - m.rg) / (K - 1.0);
          v[2] += (o.bg - m.bg) * (o.bg - m.bg) / (K - 1.0);
          se2[0] += (o.y - r.y) * (o.y - r.y) / K;
          se2[1] += (o.rg - r.rg) * (o.rg - r.rg) / K;
          se2[2] += (o.bg - r.bg) * (o.bg - r.bg) / K;
        }
        for (int q = 0; q < 3; ++q) {
          var[q] += v[q];
          var2[q] += v[q] * v[q];
        }
      }
    if (n == 0) {
      std::fprintf(stderr, "colour_noise: no lit pixels\n");
      return 2;
    }
    const double my = sum_y / n;
    std::printf("pixels %ld  images %zu  mean_Y %.6g\n", n, images.size(), my);
    std::printf("seed_sd   Y %.5f  R-G %.5f  B-G %.5f\n", std::sqrt(var[0] / n) / my, std::sqrt(var[1] / n) / my,
                std::sqrt(var[2] / n) / my);
    // Relative standard error of each sd: se(mean variance) / (2 mean variance) (delta method).
    double rel[3];
    for (int q = 0; q < 3; ++q) {
      const double mv = var[q] / n, sv = std::sqrt(std::max(0.0, var2[q] / n - mv * mv) * n / (n - 1.0));
      rel[q] = mv > 0.0 ? sv / std::sqrt(static_cast<double>(n)) / (2.0 * mv) : 0.0;
    }
    std::printf("seed_sd_relative_se  Y %.4f  R-G %.4f  B-G %.4f\n", rel[0], rel[1], rel[2]);
    if (!ref_path.empty())
      std::printf("ref_rmse  Y %.5f  R-G %.5f  B-G %.5f\n", std::sqrt(se2[0] / n) / my, std::sqrt(se2[1] / n) / my,
                  std::sqrt(se2[2] / n) / my);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "colour_noise: %s\n", e.what());
    return 2;
  }
  return 0;
}
