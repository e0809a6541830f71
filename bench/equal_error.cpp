// Equal-error speed-up of two lamina builds on one scene (issue 11's benchmark; driven by
// bench/equal_error.sh). Not run by the test suite.
//
//   equal_error [--target E] [--per-pixel] REF.exr OLD_1.exr ... -- NEW_1.exr ...
//
// Each image's error is the relative luminance RMSE against the reference,
//   rmse = sqrt(mean over pixels of (Y - Y_ref)^2) / mean Y_ref,
// over the pixels whose reference luminance is above 1 % of its mean (the black background would
// dilute it); with --per-pixel, sqrt(mean over those pixels of ((Y - Y_ref) / Y_ref)^2) instead,
// the noise as a viewer sees it in dark and bright regions alike (what adaptive sampling's
// relative threshold equalises). Its seconds come from the EXR header (lamina:seconds, the render loop only). An
// unbiased Monte Carlo render has rmse^2 = c / t (+ the reference's own noise): per build,
// c = mean over its images of rmse^2 t, and the time to reach rmse E is t(E) = c / E^2; the
// speed-up is t_old(E) / t_new(E) (their ratio does not depend on E, so E only labels it).
// It also prints each build's mean luminance against the reference's, with the standard error
// of that difference estimated from the images' own rmse (pixels independent: rmse / sqrt(n)),
// for the "mean unchanged" check: |mean - mean_ref| / se should stay below 3.
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "renderer/image/image.h"
#include "renderer/image/image_compare.h"
#include "renderer/image/image_io.h"

namespace {

struct Measure {
  double rmse = 0.0, seconds = 0.0, mean = 0.0, se_mean = 0.0;
  long spp = 0;
};

double header_number(const lamina::Metadata& meta, const std::string& key) {
  for (const auto& kv : meta)
    if (kv.first == key) return std::atof(kv.second.c_str());
  return 0.0;
}

}  // namespace

int main(int argc, char** argv) {
  double target = 0.05;
  bool per_pixel = false;
  std::vector<std::string> args;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--target" && i + 1 < argc) target = std::atof(argv[++i]);
    else if (a == "--per-pixel") per_pixel = true;
    else args.push_back(a);
  }
  std::size_t split = 0;
  while (split < args.size() && args[split] != "--") ++split;
  if (args.size() < 4 || split >= args.size() || split < 2 || split + 1 >= args.size()) {
    std::fprintf(stderr, "usage: equal_error [--target E] [--per-pixel] REF.exr OLD.exr ... -- NEW.exr ...\n");
    return 2;
  }
  try {
    const lamina::Image ref = lamina::read_image(args[0]);
    const std::vector<float> ref_y = lamina::luminance(ref);
    std::vector<std::size_t> mask;
    double ref_mean_all = 0.0;
    for (float v : ref_y) ref_mean_all += v;
    ref_mean_all /= static_cast<double>(ref_y.size());
    double ref_mean = 0.0;
    for (std::size_t i = 0; i < ref_y.size(); ++i)
      if (ref_y[i] > 0.01 * ref_mean_all) {
        mask.push_back(i);
        ref_mean += ref_y[i];
      }
    ref_mean /= static_cast<double>(mask.size());
    auto measure = [&](const std::string& path) {
      const lamina::Image im = lamina::read_image(path);
      if (im.width != ref.width || im.height != ref.height) throw std::runtime_error(path + ": size differs from the reference");
      const std::vector<float> y = lamina::luminance(im);
      Measure m;
      double se2 = 0.0, sum = 0.0;
      for (std::size_t i : mask) {
        const double v = y[i];
        const double d = per_pixel ? (v - ref_y[i]) / ref_y[i] * ref_mean : v - ref_y[i];
        se2 += d * d;
        sum += v;
      }
      const double n = static_cast<double>(mask.size());
      m.rmse = std::sqrt(se2 / n) / ref_mean;
      m.mean = sum / n;
      double abs2 = 0.0;
      for (std::size_t i : mask) abs2 += (y[i] - ref_y[i]) * (y[i] - ref_y[i]);
      m.se_mean = std::sqrt(abs2 / n) / std::sqrt(n);
      const lamina::Metadata meta = lamina::read_metadata(path);
      m.seconds = header_number(meta, "lamina:seconds");
      m.spp = static_cast<long>(header_number(meta, "lamina:spp"));
      return m;
    };
    double c[2] = {0.0, 0.0};
    const char* names[2] = {"old", "new"};
    for (int b = 0; b < 2; ++b) {
      const std::size_t first = b == 0 ? 1 : split + 1, last = b == 0 ? split : args.size();
      for (std::size_t k = first; k < last; ++k) {
        const Measure m = measure(args[k]);
        std::printf("%s %5ld spp %8.2f s  rmse %.4f  mean %.5f (ref %.5f, %+.1f se)\n", names[b], m.spp, m.seconds, m.rmse,
                    m.mean, ref_mean, (m.mean - ref_mean) / std::max(m.se_mean, 1e-300));
        c[b] += m.rmse * m.rmse * m.seconds / static_cast<double>(last - first);
      }
    }
    const double t_old = c[0] / (target * target), t_new = c[1] / (target * target);
    std::printf("time to rmse %.3f: old %.1f s, new %.1f s: equal-error speed-up %.2fx\n", target, t_old, t_new,
                t_old / t_new);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "equal_error: %s\n", e.what());
    return 2;
  }
  return 0;
}
