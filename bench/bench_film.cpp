// Timings of the film side: environment sampling and image writes.
#include <benchmark/benchmark.h>

#include <cmath>
#include <cstdio>
#include <filesystem>

#include "materials/base/sampling.h"
#include "renderer/render/environment.h"
#include "renderer/image/image_io.h"

namespace {

// A 1024 x 512 map with a small bright sun: the case importance sampling is for.
const lamina::EnvironmentMap& sun_map() {
  static const lamina::EnvironmentMap env = [] {
    lamina::Image image(1024, 512);
    for (int y = 0; y < 512; ++y)
      for (int x = 0; x < 1024; ++x) {
        float* p = image.pixel(x, y);
        const bool sun = std::abs(x - 600) < 4 && std::abs(y - 150) < 4;
        p[0] = sun ? 5e4f : 0.3f, p[1] = sun ? 4.5e4f : 0.5f, p[2] = sun ? 4e4f : 0.9f;
      }
    const std::string path = (std::filesystem::temp_directory_path() / "lamina_bench_sun.exr").string();
    lamina::write_exr(path, image);
    return lamina::EnvironmentMap::from_file(path);
  }();
  return env;
}

void BM_EnvironmentSample(benchmark::State& state) {
  const auto& env = sun_map();
  lamina::Rng rng(1, 0);
  glm::dvec3 d;
  double pdf;
  for (auto _ : state) {
    benchmark::DoNotOptimize(env.sample({rng.uniform(), rng.uniform()}, &d, &pdf));
  }
}
BENCHMARK(BM_EnvironmentSample);

void BM_EnvironmentPdf(benchmark::State& state) {
  const auto& env = sun_map();
  lamina::Rng rng(2, 0);
  for (auto _ : state) {
    benchmark::DoNotOptimize(env.pdf(lamina::sample_uniform_sphere({rng.uniform(), rng.uniform()})));
  }
}
BENCHMARK(BM_EnvironmentPdf);

void BM_WriteExr1080p(benchmark::State& state) {
  lamina::Image image(1920, 1080);
  for (std::size_t i = 0; i < image.rgb.size(); ++i) image.rgb[i] = 0.001f * static_cast<float>(i % 997);
  const std::string path = (std::filesystem::temp_directory_path() / "lamina_bench.exr").string();
  for (auto _ : state) lamina::write_exr(path, image, {{"lamina:bench", "1"}});
  std::remove(path.c_str());
}
BENCHMARK(BM_WriteExr1080p)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
