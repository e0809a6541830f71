// Comparing two renders (see image_compare.h).
#include "renderer/image/image_compare.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

#include "renderer/image/image_io.h"

namespace lamina {
namespace {

void check_same_size(const Image& a, const Image& b) {
  if (a.width != b.width || a.height != b.height)
    throw std::invalid_argument("images differ in size: " + std::to_string(a.width) + "x" +
                                std::to_string(a.height) + " and " + std::to_string(b.width) + "x" +
                                std::to_string(b.height));
}

// One pass of a normalised 1-D kernel along x (or, with along_x false, along y), cut to the image with
// the weights renormalised there.
std::vector<double> blur_pass(const std::vector<double>& in, int w, int h, const std::vector<double>& kernel, bool along_x) {
  const int r = static_cast<int>(kernel.size() / 2);
  std::vector<double> out(in.size());
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      double sum = 0.0, norm = 0.0;
      for (int k = -r; k <= r; ++k) {
        const int xx = along_x ? x + k : x, yy = along_x ? y : y + k;
        if (xx < 0 || xx >= w || yy < 0 || yy >= h) continue;
        sum += kernel[k + r] * in[static_cast<std::size_t>(yy) * w + xx];
        norm += kernel[k + r];
      }
      out[static_cast<std::size_t>(y) * w + x] = sum / norm;
    }
  return out;
}

// Separable blur with a normalised Gaussian cut to the image (weights renormalised there).
std::vector<double> gaussian_blur(const std::vector<double>& in, int w, int h, const std::vector<double>& kernel) {
  return blur_pass(blur_pass(in, w, h, kernel, true), w, h, kernel, false);
}

}  // namespace

double relative_guard_floor(const Image& reference, double epsilon) {
  double sum = 0.0;
  for (float v : reference.rgb) sum += v;
  const double mean = reference.rgb.empty() ? 0.0 : sum / static_cast<double>(reference.rgb.size());
  const double floor = epsilon * mean;
  return floor > 0.0 ? floor : kBlackReferenceFloor;
}

Image relative_difference(const Image& reference, const Image& test, double floor) {
  check_same_size(reference, test);
  Image out(reference.width, reference.height);
  for (std::size_t i = 0; i < out.rgb.size(); ++i) {
    const double ref = reference.rgb[i], t = test.rgb[i];
    out.rgb[i] = static_cast<float>((t - ref) / std::max(ref, floor));
  }
  return out;
}

std::vector<float> luminance(const Image& image) {
  std::vector<float> y(static_cast<std::size_t>(image.width) * image.height);
  for (std::size_t i = 0; i < y.size(); ++i) {
    const float* p = &image.rgb[i * 3];
    y[i] = 0.2126f * p[0] + 0.7152f * p[1] + 0.0722f * p[2];  // ITU-R BT.709
  }
  return y;
}

std::vector<float> relative_luminance_difference(const Image& reference, const Image& test, double epsilon) {
  check_same_size(reference, test);
  const std::vector<float> yr = luminance(reference), yt = luminance(test);
  double sum = 0.0;
  for (float v : yr) sum += v;
  const double mean = yr.empty() ? 0.0 : sum / static_cast<double>(yr.size());
  const double floor = epsilon * mean > 0.0 ? epsilon * mean : kBlackReferenceFloor;
  std::vector<float> rel(yr.size());
  for (std::size_t i = 0; i < yr.size(); ++i)
    rel[i] = static_cast<float>((static_cast<double>(yt[i]) - yr[i]) / std::max<double>(yr[i], floor));
  return rel;
}

CompareMetrics compare_images(const Image& reference, const Image& test, double epsilon) {
  check_same_size(reference, test);
  CompareMetrics m;
  m.guard_floor = relative_guard_floor(reference, epsilon);
  const Image rel = relative_difference(reference, test, m.guard_floor);
  const double n = static_cast<double>(reference.rgb.size());
  double sum_rel = 0.0, sum_rel2 = 0.0, sum_abs = 0.0, sum_sq = 0.0;
  for (std::size_t i = 0; i < reference.rgb.size(); ++i) {
    const double r = rel.rgb[i], d = static_cast<double>(test.rgb[i]) - reference.rgb[i];
    sum_rel += r, sum_rel2 += r * r;
    m.max_abs_relative = std::max(m.max_abs_relative, std::abs(r));
    sum_abs += std::abs(d), sum_sq += d * d;
  }
  m.mean_relative = sum_rel / n;
  m.rms_relative = std::sqrt(sum_rel2 / n);
  m.mae = sum_abs / n;
  m.mse = sum_sq / n;
  m.rmse = std::sqrt(m.mse);
  m.ssim = ssim_luminance(reference, test);
  return m;
}

double ssim_luminance(const Image& reference, const Image& test) {
  check_same_size(reference, test);
  const int w = reference.width, h = reference.height;
  const std::vector<float> yr = luminance(reference), yt = luminance(test);
  const std::size_t n = yr.size();
  std::vector<double> x(n), y(n), xx(n), yy(n), xy(n);
  for (std::size_t i = 0; i < n; ++i) {
    x[i] = srgb_encode(yr[i]);
    y[i] = srgb_encode(yt[i]);
    xx[i] = x[i] * x[i], yy[i] = y[i] * y[i], xy[i] = x[i] * y[i];
  }
  // Wang et al. 2004, section III-C: 11 x 11 circular-symmetric Gaussian, sigma 1.5.
  std::vector<double> kernel(11);
  for (int k = -5; k <= 5; ++k) kernel[k + 5] = std::exp(-0.5 * k * k / (1.5 * 1.5));
  const auto mx = gaussian_blur(x, w, h, kernel), my = gaussian_blur(y, w, h, kernel);
  const auto mxx = gaussian_blur(xx, w, h, kernel), myy = gaussian_blur(yy, w, h, kernel),
             mxy = gaussian_blur(xy, w, h, kernel);
  // Eq. 13 with C1 = (K1 L)^2, C2 = (K2 L)^2, K1 = 0.01, K2 = 0.03, L = 1.
  const double c1 = 0.01 * 0.01, c2 = 0.03 * 0.03;
  double sum = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    const double vx = mxx[i] - mx[i] * mx[i], vy = myy[i] - my[i] * my[i], cxy = mxy[i] - mx[i] * my[i];
    sum += (2.0 * mx[i] * my[i] + c1) * (2.0 * cxy + c2) /
           ((mx[i] * mx[i] + my[i] * my[i] + c1) * (vx + vy + c2));
  }
  return sum / static_cast<double>(n);  // mean SSIM, eq. 17
}

Image crop(const Image& image, int x, int y, int w, int h) {
  if (w <= 0 || h <= 0 || x < 0 || y < 0 || x + w > image.width || y + h > image.height)
    throw std::invalid_argument("crop " + std::to_string(x) + "," + std::to_string(y) + "," + std::to_string(w) +
                                "," + std::to_string(h) + " is not inside the " + std::to_string(image.width) +
                                "x" + std::to_string(image.height) + " image");
  Image out(w, h);
  for (int j = 0; j < h; ++j)
    std::copy_n(image.pixel(x, y + j), 3 * w, out.pixel(0, j));
  return out;
}

Image smooth_over_mask(const Image& image, const Image& mask, double sigma) {
  if (image.width != mask.width || image.height != mask.height)
    throw std::invalid_argument("smooth_over_mask: sizes differ");
  const int radius = std::max(1, static_cast<int>(std::ceil(3.0 * sigma)));
  std::vector<double> kernel(static_cast<std::size_t>(radius) + 1);
  for (int d = 0; d <= radius; ++d) kernel[d] = std::exp(-0.5 * d * d / (sigma * sigma));
  auto inside = [&](int x, int y) {
    const float* m = mask.pixel(x, y);
    return m[0] > 0.0f || m[1] > 0.0f || m[2] > 0.0f;
  };
  Image out = image;
  for (int y = 0; y < image.height; ++y)
    for (int x = 0; x < image.width; ++x) {
      if (!inside(x, y)) continue;
      double sum[3] = {0.0, 0.0, 0.0}, weight = 0.0;
      for (int dy = -radius; dy <= radius; ++dy) {
        const int qy = y + dy;
        if (qy < 0 || qy >= image.height) continue;
        for (int dx = -radius; dx <= radius; ++dx) {
          const int qx = x + dx;
          if (qx < 0 || qx >= image.width || !inside(qx, qy)) continue;
          const double w = kernel[std::abs(dx)] * kernel[std::abs(dy)];
          const float* p = image.pixel(qx, qy);
          for (int c = 0; c < 3; ++c) sum[c] += w * p[c];
          weight += w;
        }
      }
      float* o = out.pixel(x, y);
      for (int c = 0; c < 3; ++c) o[c] = static_cast<float>(sum[c] / weight);
    }
  return out;
}

ImagePair smoothed_pair(const Image& reference, const Image& test, double sigma) {
  if (!(sigma >= 0.0 && sigma <= kMaxSmoothSigma))
    throw std::invalid_argument("smoothed_pair: sigma " + std::to_string(sigma) + " is not in [0, " +
                                std::to_string(static_cast<int>(kMaxSmoothSigma)) + "]");
  if (sigma == 0.0) return {reference, test};
  // Both over the reference's non-black pixels: the reference's mask for both.
  return {smooth_over_mask(reference, reference, sigma), smooth_over_mask(test, reference, sigma)};
}

}  // namespace lamina
