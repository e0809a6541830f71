// Issue 13 item 6, measured: a colour texture -> two parameter maps through the albedo lookup
// (materials/albedo_lookup.h), and how well the stack's albedo then matches the texture.
//   albedo_map TEXTURE STACK.json OUT_DIR [NODES]
// Axes: the skin preset's epidermal melanin fraction (layers[0].components[0].fraction, 0..0.3)
// and dermal blood fraction (layers[1].components[0].fraction, 0..0.2). Writes OUT_DIR/melanin.png
// and OUT_DIR/blood.png (the fraction / its range's top, stored as 8-bit values, which texture
// bindings read as stored), OUT_DIR/skin_fitted_map.json (a `lamina render --materials` map binding
// them), and prints the table's build time, the matching time and the colour difference between
// the texture and the matched albedo (CIE76 Delta E: mean, 95th percentile, max).
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <tbb/parallel_for.h>

#include "materials/albedo_lookup.h"
#include "materials/stack_file.h"
#include "renderer/image/image_io.h"

int main(int argc, char** argv) {
  if (argc < 4) {
    std::fprintf(stderr, "usage: albedo_map TEXTURE STACK.json OUT_DIR [NODES]\n");
    return 2;
  }
  try {
    const std::string texture = argv[1], stack_path = argv[2], out = argv[3];
    const int nodes = argc > 4 ? std::atoi(argv[4]) : 33;
    const lamina::StackTemplate t = lamina::load_stack_template(stack_path);
    const std::vector<lamina::FitParameterSpec> axes = {{"layers[0].components[0].fraction", 0.0, 0.3},
                                                        {"layers[1].components[0].fraction", 0.0, 0.2}};
    using clock = std::chrono::steady_clock;
    auto t0 = clock::now();
    const lamina::AlbedoLookup table = lamina::build_albedo_lookup(t, axes, nodes, lamina::AddingDoublingSettings{8});
    auto t1 = clock::now();
    const lamina::Image img = lamina::read_image(texture);
    lamina::Image melanin(img.width, img.height), blood(img.width, img.height);
    std::vector<double> de(static_cast<std::size_t>(img.width) * img.height);
    // Texels are independent: rows in parallel, each result in its own place (any thread count
    // gives the same maps).
    tbb::parallel_for(0, img.height, [&](int y) {
      for (int x = 0; x < img.width; ++x) {
        const float* p = img.pixel(x, y);
        const lamina::AlbedoMatch m = lamina::match_albedo(table, lamina::Spectrum(p[0], p[1], p[2]));
        de[static_cast<std::size_t>(y) * img.width + x] = m.delta_e;
        float* a = melanin.pixel(x, y);
        float* b = blood.pixel(x, y);
        // Parameter maps are read as stored (renderer/layered/stack_bindings.h: no sRGB decoding),
        // and write_png stores srgb_encode(value): so hand it srgb_decode(t) to store t.
        a[0] = a[1] = a[2] = static_cast<float>(lamina::srgb_decode(m.value[0] / axes[0].upper));
        b[0] = b[1] = b[2] = static_cast<float>(lamina::srgb_decode(m.value[1] / axes[1].upper));
      }
    });
    auto t2 = clock::now();
    lamina::write_png(out + "/melanin.png", melanin);
    lamina::write_png(out + "/blood.png", blood);
    std::ofstream(out + "/skin_fitted_map.json")
        << "{ \"skin\": { \"stack\": \"" << std::filesystem::absolute(stack_path).string() << "\", \"bind\": [\n"
        << "  { \"parameter\": \"" << axes[0].path << "\", \"texture\": \"melanin.png\", \"channel\": \"r\", \"range\": [0, " << axes[0].upper << "] },\n"
        << "  { \"parameter\": \"" << axes[1].path << "\", \"texture\": \"blood.png\", \"channel\": \"r\", \"range\": [0, " << axes[1].upper << "] } ] } }\n";
    std::vector<double> sorted = de;
    std::sort(sorted.begin(), sorted.end());
    double mean = 0.0;
    for (double e : de) mean += e;
    mean /= static_cast<double>(de.size());
    const double p95 = sorted[static_cast<std::size_t>(0.95 * (sorted.size() - 1))];
    const double p50 = sorted[sorted.size() / 2];
    std::printf("table %dx%d (8 quadrature points): %.2f s; matching %dx%d texels: %.2f s\n", nodes, nodes,
                std::chrono::duration<double>(t1 - t0).count(), img.width, img.height,
                std::chrono::duration<double>(t2 - t1).count());
    std::printf("Delta E76 texture vs matched albedo: mean %.2f, median %.2f, 95th percentile %.2f, max %.2f\n", mean, p50,
                p95, sorted.back());
  } catch (const std::exception& e) {
    std::fprintf(stderr, "albedo_map: %s\n", e.what());
    return 1;
  }
  return 0;
}
