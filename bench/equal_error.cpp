// Equal-error speed-up of two lamina builds on one scene (driven by
// bench/equal_error.sh). Not run by the test suite.
//
//   equal_error [--target E] [--per-pixel] REF.exr OLD_1.exr ... -- NEW_1.exr ...
//
// Each image's error is the relative luminance RMSE against the reference,
//   rmse = sqrt(mean over pixels of (Y - Y_ref)^2) / mean Y_ref,
// over the pixels whose reference luminance is above 1 % of its mean (the black background would
// dilute it); with --per-pixel, sqrt(mean over those pixels of ((Y - Y_ref) / Y_ref)^2) instead,
// the noise as a viewer sees it in dark and bright regions alike (what adaptive sampling's
// relative threshold equalises). Its seconds come from the EXR header (lamina:seconds, the render
// loop only), its samples per pixel n from lamina:spp.
//
// The time to reach rmse E. An unbiased Monte Carlo render of n spp has E[rmse^2] = V / n +
// V_ref: V the per-sample variance (relative, summed over the measured pixels' mean), V_ref the
// reference's own variance. The reference is rendered by the NEW build (bench/equal_error.sh), so
// V_ref = V_new / N_ref, and a new image estimates V_new = n rmse^2 / (1 + n / N_ref); every image
// then gives n (rmse^2 - V_ref) for its build. The time grows as t = t0 + k n (t0: what a render
// costs besides its samples). So t(E) = t0 + k V / E^2, and at E = 5 % (about a thousand spp
// here) t0 is negligible: t(E) = k V / E^2, with k the least-squares slope of seconds against spp
// and V the images' estimates weighted by their spp (a heavy-tailed walk's rare large samples are
// missed more often by a small image, whose rmse^2 then falls short of V / n; the largest image
// has the most reliable rmse). The speed-up is t_old(E) / t_new(E) (its ratio does not depend on
// E, so E only labels it).
// The plain estimator, c = mean over a build's images of rmse^2 t and t(E) =
// c / E^2, is printed too ("plain"): it keeps the reference's noise, the renders' fixed cost and
// the small images' shortfall, which all lower the ratio of a build much faster than the other.
// It also prints each build's mean luminance against the reference's, with the standard error
// of that difference estimated from the images' own rmse (pixels independent: rmse / sqrt(n)),
// for the "mean unchanged" check: |mean - mean_ref| / se should stay below 3.
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <stdexcept>
#include <string>
#include <vector>

#include "renderer/image/image.h"
#include "renderer/image/image_compare.h"
#include "renderer/image/image_io.h"

namespace {

struct Measure {
  double rmse = 0.0, seconds = 0.0, mean = 0.0, se_mean = 0.0;
  long spp = 0;
  std::vector<float> y;  // luminance over the measured pixels
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
    // A luminance difference at a measured pixel as the rmse counts it: as it is, or (--per-pixel)
    // relative to the reference there, in units of the reference's mean.
    auto counted = [&](double difference, std::size_t pixel) {
      return per_pixel ? difference / ref_y[pixel] * ref_mean : difference;
    };
    auto measure = [&](const std::string& path) {
      const lamina::Image im = lamina::read_image(path);
      if (im.width != ref.width || im.height != ref.height) throw std::runtime_error(path + ": size differs from the reference");
      const std::vector<float> y = lamina::luminance(im);
      Measure m;
      m.y.reserve(mask.size());
      for (std::size_t i : mask) m.y.push_back(y[i]);
      double se2 = 0.0, sum = 0.0;
      for (std::size_t i : mask) {
        const double v = y[i];
        const double d = counted(v - ref_y[i], i);
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
    const double n_ref = header_number(lamina::read_metadata(args[0]), "lamina:spp");
    std::vector<Measure> measures[2];
    const char* names[2] = {"old", "new"};
    for (int b = 0; b < 2; ++b) {
      const std::size_t first = b == 0 ? 1 : split + 1, last = b == 0 ? split : args.size();
      for (std::size_t k = first; k < last; ++k) {
        const Measure m = measure(args[k]);
        if (!(m.spp > 0) || !(m.seconds > 0.0)) throw std::runtime_error(args[k] + ": no lamina:spp or lamina:seconds in its header");
        std::printf("%s %5ld spp %8.2f s  rmse %.4f  mean %.5f (ref %.5f, %+.1f se)\n", names[b], m.spp, m.seconds, m.rmse,
                    m.mean, ref_mean, (m.mean - ref_mean) / std::max(m.se_mean, 1e-300));
        measures[b].push_back(m);
      }
    }
    // The reference's variance from the new images (weighted by spp, as V below).
    double v_new = 0.0, w_new = 0.0;
    for (const Measure& m : measures[1]) {
      const double n = static_cast<double>(m.spp);
      v_new += n * (n * m.rmse * m.rmse / (1.0 + (n_ref > 0.0 ? n / n_ref : 0.0)));
      w_new += n;
    }
    const double v_ref = n_ref > 0.0 ? v_new / w_new / n_ref : 0.0;
    // Per-sample variance from two renders of the same spp and build with different seeds: the
    // mean over pixels of (y1 - y2)^2 / 2 is V / n with no reference in it (neither its noise nor
    // a difference between what the two builds render: on head_skin_smooth at 1024 spp an older build's
    // image differed from a newer build's by about 5 % per pixel (rms) beyond the noise of both:
    // a normal map the old build did not read and freckles whose spots moved with the random-number
    // generator: a floor under its rmse against the new reference that no number of samples
    // removes).
    auto pair_variance = [&](const Measure& a, const Measure& b) {
      double d2 = 0.0;
      for (std::size_t i = 0; i < a.y.size(); ++i) {
        const double d = counted(a.y[i] - b.y[i], mask[i]);
        d2 += d * d;
      }
      return static_cast<double>(a.spp) * d2 / (2.0 * static_cast<double>(a.y.size())) / (ref_mean * ref_mean);
    };
    double t_plain[2], t_fit[2];
    bool from_pairs[2];
    for (int b = 0; b < 2; ++b) {
      const std::vector<Measure>& ms = measures[b];
      double c = 0.0, v_rmse = 0.0, w_rmse = 0.0, v_pairs = 0.0, w_pairs = 0.0;
      double sn = 0.0, st = 0.0, snn = 0.0, snt = 0.0;
      for (std::size_t i = 0; i < ms.size(); ++i) {
        const Measure& m = ms[i];
        const double n = static_cast<double>(m.spp);
        c += m.rmse * m.rmse * m.seconds / static_cast<double>(ms.size());
        v_rmse += n * (n * (m.rmse * m.rmse - v_ref));
        w_rmse += n;
        for (std::size_t j = i + 1; j < ms.size(); ++j)
          if (ms[j].spp == m.spp) {
            const double v_pair = pair_variance(m, ms[j]);
            std::printf("%s %5ld spp seed pair: per-sample variance %.4f\n", names[b], m.spp, v_pair);
            v_pairs += n * v_pair;
            w_pairs += n;
          }
        sn += n, st += m.seconds, snn += n * n, snt += n * m.seconds;
      }
      from_pairs[b] = w_pairs > 0.0;
      const double v = from_pairs[b] ? v_pairs / w_pairs : v_rmse / w_rmse;
      const double count = static_cast<double>(ms.size());
      const double det = count * snn - sn * sn;
      // One spp only: no slope; then the time per spp of that image (t0 included).
      const double k = det > 0.0 ? (count * snt - sn * st) / det : st / sn;
      t_plain[b] = c / (target * target);
      t_fit[b] = k * v / (target * target);
      std::printf("%s: per-sample variance %.4f (%s; against the reference %.4f), %.4f s per spp\n", names[b], v,
                  from_pairs[b] ? "from seed pairs" : "against the reference, its own noise removed", v_rmse / w_rmse, k);
    }
    std::printf("reference: %g spp, its variance %.6f (the new build's per-sample variance / %g)\n", n_ref, v_ref, n_ref);
    if (!from_pairs[0] || !from_pairs[1])
      std::printf("note: a build without two renders of one spp is measured against the reference (EQ_REPEAT=2 for seed pairs)\n");
    std::printf("time to rmse %.3f: old %.1f s, new %.1f s: equal-error speed-up %.2fx (plain: %.1f s, %.1f s, %.2fx)\n",
                target, t_fit[0], t_fit[1], t_fit[0] / t_fit[1], t_plain[0], t_plain[1], t_plain[0] / t_plain[1]);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "equal_error: %s\n", e.what());
    return 2;
  }
  return 0;
}
