// lamina compare REFERENCE TEST [-o DIFF.exr] [--png DIFF.png] [--json METRICS.json]
//                [--range R] [--crop x,y,w,h] [--epsilon E] [--fail-above X]
//
// Exit status: 0 when done, 1 when --fail-above is exceeded, 2 on bad input (one-line error).
// Every number is checked by renderer/cli/options.h (finite, in range) and every output path
// before the images are read; the outputs are written all or none (renderer/cli/outputs.h).
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "renderer/cli/commands.h"
#include "renderer/cli/options.h"
#include "renderer/cli/outputs.h"
#include "renderer/util/atomic_file.h"
#include "renderer/image/false_colour.h"
#include "renderer/image/image_compare.h"
#include "renderer/image/image_io.h"
#include "renderer/util/python_plot.h"
#include "renderer/util/string_format.h"

namespace lamina {
namespace {

struct CompareArgs {
  std::string reference, test, out_exr, out_png, out_json, out_plot;
  double range = 0.5;
  double epsilon = kDefaultGuardEpsilon;
  std::vector<int> crop;
  double fail_above = -1.0;
  double smooth = 0.0;  // Gaussian sigma in pixels, 0: none
};

Image read_checked(const std::string& path, int* channels) {
  Image image = read_image(path, channels);
  for (int y = 0; y < image.height; ++y)
    for (int x = 0; x < image.width; ++x)
      for (int c = 0; c < 3; ++c)
        if (!std::isfinite(image.pixel(x, y)[c]))
          throw std::runtime_error("'" + path + "': pixel (" + std::to_string(x) + ", " + std::to_string(y) +
                                   ") is not finite");
  return image;
}

int compare(const CompareArgs& args) {
  const std::vector<cli::OutputPath> output_paths = {{"--output", args.out_exr}, {"--png", args.out_png}, {"--json", args.out_json}, {"--plot", args.out_plot}};
  cli::check_output_paths(output_paths);
  cli::check_outputs_not_inputs(output_paths, {{"the reference", args.reference}, {"the test image", args.test}});
  if (!args.out_plot.empty() && (!args.crop.empty() || args.smooth > 0.0))
    throw std::runtime_error("--plot: not with --crop or --smooth (the plot shows the whole images as they are)");
  int ref_channels = 0, test_channels = 0;
  Image ref = read_checked(args.reference, &ref_channels);
  Image test = read_checked(args.test, &test_channels);
  if (ref.width != test.width || ref.height != test.height)
    throw std::runtime_error("'" + args.reference + "' is " + std::to_string(ref.width) + "x" +
                             std::to_string(ref.height) + " but '" + args.test + "' is " +
                             std::to_string(test.width) + "x" + std::to_string(test.height));
  if (ref_channels != test_channels)
    throw std::runtime_error("'" + args.reference + "' has " + std::to_string(ref_channels) + " colour channel(s) but '" +
                             args.test + "' has " + std::to_string(test_channels));
  if (!args.crop.empty()) {
    ref = crop(ref, args.crop[0], args.crop[1], args.crop[2], args.crop[3]);
    test = crop(test, args.crop[0], args.crop[1], args.crop[2], args.crop[3]);
  }

  if (args.smooth > 0.0) {
    ImagePair smoothed = smoothed_pair(ref, test, args.smooth);
    ref = std::move(smoothed.reference);
    test = std::move(smoothed.test);
    std::printf("both images smoothed by a Gaussian of sigma %g px over the reference's non-black pixels\n", args.smooth);
  }
  const CompareMetrics m = compare_images(ref, test, args.epsilon);
  std::printf("compared %dx%d pixels (relative difference guarded at %.4g = %g x mean reference)\n", ref.width,
              ref.height, m.guard_floor, args.epsilon);
  std::printf("mean relative difference  %+.6f (%+.3f%%)\n", m.mean_relative, 100.0 * m.mean_relative);
  std::printf("RMS relative difference   %.6f (%.3f%%)\n", m.rms_relative, 100.0 * m.rms_relative);
  std::printf("max |relative difference| %.6f\n", m.max_abs_relative);
  std::printf("MAE %.6g  MSE %.6g  RMSE %.6g\n", m.mae, m.mse, m.rmse);
  std::printf("SSIM (display luminance, Wang et al. 2004) %.6f\n", m.ssim);

  // All outputs or none: each is written to a temporary, and they are renamed into place together.
  cli::StagedOutputs outputs;
  if (!args.out_exr.empty()) {
    const Image rel = relative_difference(ref, test, m.guard_floor);
    // A derived image keeps its input's place: the window of a reference that is a crop of a
    // render, moved by --crop's offset (a whole reference gives a whole image, as before).
    DataWindow window = read_data_window(args.reference);
    if (!args.crop.empty() && window.full_width > 0) {
      window.x += args.crop[0];
      window.y += args.crop[1];
    }
    outputs.write(args.out_exr, [&](const std::string& tmp) {
      write_exr(tmp, rel,
                {{"lamina:compare:reference", args.reference},
                 {"lamina:compare:test", args.test},
                 {"lamina:compare:definition", "(TEST - REF) / max(REF, guard_floor)"},
                 {"lamina:compare:guard_floor", std::to_string(m.guard_floor)},
                 {"lamina:compare:smooth_sigma", string_printf("%g", args.smooth)}},
                {}, window);
    });
  }
  if (!args.out_png.empty()) {
    const std::vector<float> rel = relative_luminance_difference(ref, test, args.epsilon);
    outputs.write(args.out_png, [&](const std::string& tmp) {
      write_png(tmp, false_colour_with_legend(rel, ref.width, ref.height, args.range, difference_caption(args.smooth)));
    });
  }
  if (!args.out_json.empty()) {
    nlohmann::json j;
    j["reference"] = args.reference;
    j["test"] = args.test;
    j["width"] = ref.width;
    j["height"] = ref.height;
    if (!args.crop.empty()) j["crop"] = args.crop;
    j["guard_epsilon"] = args.epsilon;
    j["guard_floor"] = m.guard_floor;
    j["range"] = args.range;
    j["smooth_sigma"] = args.smooth;
    j["mean_relative"] = m.mean_relative;
    j["rms_relative"] = m.rms_relative;
    j["max_abs_relative"] = m.max_abs_relative;
    j["mae"] = m.mae;
    j["mse"] = m.mse;
    j["rmse"] = m.rmse;
    j["ssim"] = m.ssim;
    cli::check_finite_numbers(j, "--json '" + args.out_json + "'");
    outputs.write(args.out_json, [&](const std::string& tmp) { write_file_atomically(tmp, j.dump(2) + "\n"); });
  }
  if (!args.out_plot.empty())
    run_python_plot({"compare", args.reference, args.test, args.out_plot, "--epsilon", string_printf("%.17g", args.epsilon),
                     "--range", string_printf("%.17g", args.range)});
  outputs.commit();
  if (args.fail_above >= 0.0 && m.rms_relative > args.fail_above) {
    std::fprintf(stderr, "lamina compare: RMS relative difference %.6g exceeds --fail-above %.6g\n", m.rms_relative,
                 args.fail_above);
    return 1;
  }
  return 0;
}

}  // namespace
}  // namespace lamina

int run_compare(int argc, char** argv) {
  lamina::CompareArgs args;
  CLI::App app{
      "Relative difference (TEST - REF) / max(REF, epsilon * mean(REF)) of two linear images, as an EXR and a "
      "false-colour PNG (red: TEST brighter, blue: darker), with error metrics.",
      "lamina compare"};
  app.add_option("reference", args.reference, "Reference image (EXR, HDR, PNG, JPEG)")->required();
  app.add_option("test", args.test, "Image to compare with the reference")->required();
  app.add_option("-o,--output", args.out_exr, "Write the per-channel relative difference as a float EXR");
  app.add_option("--png", args.out_png, "Write the false-colour picture (luminance) with a legend");
  app.add_option("--json", args.out_json, "Write the metrics as JSON");
  app.add_option("--plot", args.out_plot,
                 "Write a histogram of the relative differences beside the false-colour image as a PNG (with the Python "
                 "package's matplotlib, docs/python.md; not with --crop or --smooth)");
  app.add_option("--range", args.range, "Relative difference drawn as full red/blue (default 0.5 = 50%)")
      ->check(lamina::cli::positive());
  app.add_option("--epsilon", args.epsilon, "Guard: divide by max(REF, epsilon * mean(REF)) (default 0.01)")
      ->check(lamina::cli::positive());
  // x and y >= 0, w and h >= 1; that the region lies inside the image is checked by crop().
  constexpr long long kMaxInt = std::numeric_limits<int>::max();
  app.add_option("--crop", args.crop, "Compare only the region x,y,w,h")
      ->delimiter(',')
      ->expected(4)
      ->check(lamina::cli::integer(0, kMaxInt, "x").application_index(0))
      ->check(lamina::cli::integer(0, kMaxInt, "y").application_index(1))
      ->check(lamina::cli::integer(1, kMaxInt, "w").application_index(2))
      ->check(lamina::cli::integer(1, kMaxInt, "h").application_index(3));
  app.add_option("--smooth", args.smooth,
                 "Smooth both images by a Gaussian of this sigma in pixels over the reference's non-black pixels first "
                 "(shows the pattern of a difference of noisy renders; the legend says so)")
      ->check(lamina::cli::real(0.0, lamina::kMaxSmoothSigma, true, false));
  app.add_option("--fail-above", args.fail_above, "Exit with status 1 if the RMS relative difference exceeds X")
      ->check(lamina::cli::non_negative());
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);  // prints the help, status 0
  } catch (const CLI::ParseError& e) {
    std::fprintf(stderr, "lamina compare: %s (see 'lamina compare --help')\n", lamina::cli::parse_error_line(e).c_str());
    return 2;
  }
  try {
    return lamina::compare(args);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "lamina compare: %s\n", lamina::cli::one_line(e.what()).c_str());
    return 2;
  }
}
