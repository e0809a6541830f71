// fireflies IMAGE.exr [...]: counts the pixels whose luminance is more than twice the median of
// their 5x5 neighbourhood (and above 1 % of the image's mean luminance, so that black regions do
// not count), the measure quoted for the Cornell box and the leaves, and those more than
// ten times it: at low sample counts plain noise passes the first test, while a firefly (a rare
// path carrying far more than its share) passes both. Prints one line per image: the two counts,
// the pixels, and the share of the image's light above the medians of the first kind.
#include <algorithm>
#include <cstdio>
#include <vector>

#include "renderer/image/image_compare.h"
#include "renderer/image/image_io.h"

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: fireflies IMAGE.exr [...]\n");
    return 2;
  }
  for (int a = 1; a < argc; ++a) {
    const lamina::Image im = lamina::read_image(argv[a]);
    const std::vector<float> y = lamina::luminance(im);
    double mean = 0.0;
    for (float v : y) mean += v;
    mean /= static_cast<double>(y.size());
    int count = 0, count10 = 0;
    double light = 0.0;
    std::vector<float> window;
    for (int py = 0; py < im.height; ++py)
      for (int px = 0; px < im.width; ++px) {
        window.clear();
        for (int dy = -2; dy <= 2; ++dy)
          for (int dx = -2; dx <= 2; ++dx) {
            const int qx = px + dx, qy = py + dy;
            if (qx >= 0 && qy >= 0 && qx < im.width && qy < im.height) window.push_back(y[static_cast<std::size_t>(qy) * im.width + qx]);
          }
        std::nth_element(window.begin(), window.begin() + window.size() / 2, window.end());
        const double median = window[window.size() / 2];
        const double v = y[static_cast<std::size_t>(py) * im.width + px];
        if (v > 2.0 * median && v > 0.01 * mean) {
          ++count;
          count10 += v > 10.0 * median;
          light += v - median;
        }
      }
    std::printf("%s: %d pixels > 2x their 5x5 median, %d > 10x, of %d pixels; %.2f%% of the image's light above their medians\n",
                argv[a], count, count10, im.width * im.height, 100.0 * light / (mean * static_cast<double>(y.size())));
  }
  return 0;
}
