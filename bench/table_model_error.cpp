// The table mode's model error along texture-driven parameters, without noise: for texels on a
// stratified grid over UV space, the table the model gives for the texel's parameters
// (renderer/layered/layered_tables.h: node tables interpolated and multiplied) against the
// adding-doubling table of the texel's own stack (the truth of the table mode at that texel).
//   table_model_error SCENE.gltf [--grid N] [--material INDEX]
// Prints, over the texels: the signed mean and the RMS of the relative error of the directional
// albedo (sum over bins of f times the bin's projected solid angle, per channel) at incidences
// of 0 and 60 degrees, and the relative RMS of the bins (sum of squared differences over all
// nodes, bins and channels over the sum of squared true values), then the ten worst texels.
// docs/performance.md, "The face benchmark".
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "materials/tables/layered_table.h"
#include "renderer/layered/layered_tables.h"
#include "renderer/layered/material_binding.h"
#include "renderer/layered/stack_bindings.h"
#include "renderer/scene/scene_gltf.h"

namespace {

struct TexelError {
  double u = 0, v = 0;
  double albedo[2][lamina::kChannels] = {};  // relative, at 0 and 60 degrees
  double bins_sq = 0, truth_sq = 0;
};

}  // namespace

int main(int argc, char** argv) {
  using namespace lamina;
  if (argc < 2) {
    std::fprintf(stderr, "usage: table_model_error SCENE.gltf [--grid N] [--material INDEX]\n");
    return 2;
  }
  int grid = 10, material = 0;
  for (int i = 2; i + 1 < argc; i += 2) {
    const std::string a = argv[i];
    if (a == "--grid") grid = std::atoi(argv[i + 1]);
    else if (a == "--material") material = std::atoi(argv[i + 1]);
  }
  const SceneDesc desc = load_gltf(argv[1]);
  const LayeredBindings bindings = bind_layered_materials(desc, "");
  const LayeredMaterial* m = bindings.get(material);
  if (!m || !m->bindings() || m->bindings()->empty()) {
    std::fprintf(stderr, "table_model_error: material %d has no texture-driven parameters\n", material);
    return 1;
  }
  const TableSettings ts;
  const LayeredTables tables(bindings, ts);
  std::printf("tables: %d along the parameters, %.2f s\n", tables.parameter_tables(), tables.build_seconds());
  const LayeredTable& base = tables.get(m, false);
  const StackBindings& b = *m->bindings();
  for (std::size_t k = 0; k < b.parameters().size(); ++k) {
    const StackBindings::Nodes n = b.nodes(k, LayeredTables::kParameterNodes);
    std::printf("parameter %zu nodes:", k);
    for (std::size_t j = 0; j < n.values.size(); ++j) std::printf(" %.4g%s", n.values[j][n.channel], j == n.central ? "*" : "");
    std::printf("\n");
  }
  const int B = base.bins(), K = ts.bins_theta, M = ts.bins_phi;
  // Nodes nearest 0 and 60 degrees.
  int views[2] = {ts.nodes - 1, 0};
  for (int j = 0; j < ts.nodes; ++j)
    if (std::abs(table_node_cosine(ts, j) - 0.5) < std::abs(table_node_cosine(ts, views[1]) - 0.5)) views[1] = j;
  std::vector<TexelError> errors;
  for (int iy = 0; iy < grid; ++iy)
    for (int ix = 0; ix < grid; ++ix) {
      TexelError e;
      e.u = (ix + 0.5) / grid;
      e.v = (iy + 0.5) / grid;
      StackScratch scratch;
      ShadingPoint sp;
      sp.uv = {e.u, e.v};
      const LayerStack& stack = m->stack_at(sp, scratch);
      std::vector<Spectrum> values(b.parameters().size());
      b.values(sp.uv, values.data());
      TableFactor factors[LayeredTables::kMaxFactors];
      const int n = tables.factors(m, false, values.data(), factors);
      const LayeredTable truth = build_layered_table(stack, ts);
      for (int node = 0; node < ts.nodes; ++node) {
        Spectrum a_model(0.0), a_truth(0.0);
        for (int bin = 0; bin < B; ++bin) {
          const Spectrum f = table_model_value(base, factors, n, node, bin);
          const Spectrum t = truth.at(node, bin);
          const double omega = truth.projected_solid_angle((bin / M) % K);
          a_model += f * omega;
          a_truth += t * omega;
          for (int c = 0; c < kChannels; ++c) {
            e.bins_sq += (f[c] - t[c]) * (f[c] - t[c]);
            e.truth_sq += t[c] * t[c];
          }
        }
        for (int w = 0; w < 2; ++w)
          if (node == views[w])
            for (int c = 0; c < kChannels; ++c) e.albedo[w][c] = a_model[c] / a_truth[c] - 1.0;
      }
      errors.push_back(e);
    }
  double mean[2][kChannels] = {}, rms[2][kChannels] = {}, sq = 0, tsq = 0;
  for (const TexelError& e : errors) {
    for (int w = 0; w < 2; ++w)
      for (int c = 0; c < kChannels; ++c) {
        mean[w][c] += e.albedo[w][c] / errors.size();
        rms[w][c] += e.albedo[w][c] * e.albedo[w][c] / errors.size();
      }
    sq += e.bins_sq;
    tsq += e.truth_sq;
  }
  std::printf("%zu texels (grid %d x %d over UV)\n", errors.size(), grid, grid);
  for (int w = 0; w < 2; ++w)
    std::printf("directional albedo at %2.0f deg: mean relative error %+.4f %+.4f %+.4f, RMS %.4f %.4f %.4f\n",
                std::acos(table_node_cosine(ts, views[w])) * 180.0 / 3.14159265358979, mean[w][0], mean[w][1], mean[w][2],
                std::sqrt(rms[w][0]), std::sqrt(rms[w][1]), std::sqrt(rms[w][2]));
  std::printf("bins: relative RMS %.4f\n", std::sqrt(sq / tsq));
  std::sort(errors.begin(), errors.end(), [](const TexelError& x, const TexelError& y) {
    return std::abs(x.albedo[0][0]) > std::abs(y.albedo[0][0]);
  });
  std::printf("worst texels (by the red albedo at normal incidence): u v, albedo error R G B, bins relative RMS, parameters\n");
  for (std::size_t i = 0; i < std::min<std::size_t>(10, errors.size()); ++i) {
    const TexelError& e = errors[i];
    std::vector<Spectrum> values(b.parameters().size());
    b.values({e.u, e.v}, values.data());
    std::printf("%.3f %.3f  %+.4f %+.4f %+.4f  %.4f ", e.u, e.v, e.albedo[0][0], e.albedo[0][1], e.albedo[0][2],
                std::sqrt(e.bins_sq / e.truth_sq));
    for (const Spectrum& v : values) std::printf(" %.4g", v[0]);
    std::printf("\n");
  }
  return 0;
}
