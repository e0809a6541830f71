// The record of adding-doubling's discretisation error estimate on forward-peaked slabs
// (docs/adding_doubling.md, "Forward-peaked phase functions"): for slabs of index 1 and 1.4,
// optical thickness 1 and 10 (albedo 0.99), g 0.8 to 0.999, at 0 and 60 degrees and 16, 32 and
// 64 points, the error of the four totals (R, T collimated; R, T diffuse incidence) against the
// solution at 256 points, and whether adding_doubling_with_error's estimate bounds it (to 1e-6,
// the 256-point solution's own uncertainty at g = 0.999); also the plain difference from N/2
// points, the estimate without the extrapolation, for comparison. Prints each case the estimate
// misses and a summary per g. Not a timing; about a minute on one core.
// Usage: forward_peaked_error
#include <cmath>
#include <cstdio>
#include <algorithm>
#include <map>
#include <vector>

#include "materials/adding_doubling/adding_doubling.h"

int main() {
  using namespace lamina;
  std::printf("%-6s %8s %12s %12s %14s\n", "g", "cases", "est. misses", "N/2 misses", "median est/err");
  for (double g : {0.8, 0.9, 0.95, 0.99, 0.999}) {
    int cases = 0, misses = 0, plain_misses = 0;
    std::vector<double> ratios;
    for (double n : {1.0, 1.4})
      for (double tau : {1.0, 10.0})
        for (double theta : {0.0, 60.0}) {
          LayerStack s;
          s.layers = {make_layer("slab", n, 1.0, Spectrum(0.01 * tau), Spectrum(0.99 * tau), Spectrum(g))};
          const double mu = std::cos(theta * 3.14159265358979323846 / 180.0);
          std::map<int, AddingDoublingTotals> plain;
          auto at = [&](int q) {
            if (!plain.count(q)) {
              AddingDoublingSettings st;
              st.quadrature_points = q;
              st.only_channel = 0;
              plain[q] = adding_doubling_totals(s, mu, st);
            }
            return plain[q];
          };
          auto X = [](const AddingDoublingTotals& t, int k) {
            return k == 0 ? t.R_specular[0] + t.R_diffuse[0]
                 : k == 1 ? t.T_ballistic[0] + t.T_diffuse[0]
                 : k == 2 ? t.R_hemispherical[0]
                          : t.T_hemispherical[0];
          };
          auto E = [](const AddingDoublingTotals& d, int k) {
            return k == 0 ? d.R_specular[0] + d.R_diffuse[0]
                 : k == 1 ? d.T_ballistic[0] + d.T_diffuse[0]
                 : k == 2 ? d.R_hemispherical[0]
                          : d.T_hemispherical[0];
          };
          const AddingDoublingTotals ref = at(256);
          for (int q : {16, 32, 64}) {
            AddingDoublingSettings st;
            st.quadrature_points = q;
            st.only_channel = 0;
            const AddingDoublingEstimate e = adding_doubling_with_error(s, mu, st);
            for (int k = 0; k < 4; ++k) {
              const double err = std::abs(X(e.totals, k) - X(ref, k));
              const double est = E(e.error, k), half = std::abs(X(at(q), k) - X(at(q / 2), k));
              ++cases;
              ratios.push_back((est + 1e-12) / (err + 1e-12));
              if (half + 1e-6 < err) ++plain_misses;
              if (est + 1e-6 < err) {
                ++misses;
                std::printf("  miss: n %.1f tau %2.0f g %.3f theta %2.0f points %2d %s: error %.2e estimate %.2e%s\n", n,
                            tau, g, theta, q, k == 0 ? "R" : k == 1 ? "T" : k == 2 ? "R_hemispherical" : "T_hemispherical",
                            err, est, e.extrapolated ? " (extrapolated)" : "");
              }
            }
          }
        }
    std::sort(ratios.begin(), ratios.end());
    std::printf("%-6.3f %8d %12d %12d %14.1f\n", g, cases, misses, plain_misses, ratios[ratios.size() / 2]);
  }
  return 0;
}
