// lamina denoise IN.exr -o OUT.exr [--png OUT.png] [--exposure EV] [--tone-curve C] [--no-aux]
//                [--threads N]
//
// Open Image Denoise on a rendered EXR (renderer/image/denoise.h), guided by its albedo and
// normal AOVs (lamina render --aovs albedo,normal) when it has them. The input is never changed:
// the denoised image is a new EXR with the input's header and lamina:denoised. Exit status: 0
// when done, 1 when the denoiser fails, 2 on bad input (one-line error).
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>

#include <CLI/CLI.hpp>

#include "renderer/cli/commands.h"
#include "renderer/cli/options.h"
#include "renderer/cli/outputs.h"
#include "renderer/image/denoise.h"
#include "renderer/image/image_io.h"
#include "renderer/image/tone_map.h"
#include "renderer/util/string_format.h"

int run_denoise(int argc, char** argv) {
  using namespace lamina;
  CLI::App app("Denoises a rendered EXR with Intel Open Image Denoise, guided by its albedo and normal AOVs.",
               "lamina denoise");
  std::string in_path, out_path, png_path;
  ToneMap tone_map;
  std::string tone_curve = tone_curve_name(tone_map.curve);
  bool no_aux = false;
  int threads = 0;
  app.add_option("input", in_path, "EXR written by lamina render (with --aovs albedo,normal for the best result)")->required();
  app.add_option("-o,--out", out_path, "denoised EXR")->required();
  app.add_option("--png", png_path, "also write a tone-mapped sRGB PNG");
  app.add_option("--exposure", tone_map.exposure, "PNG only: stops of exposure before the tone curve")
      ->capture_default_str()
      ->check(cli::real(-20.0, 20.0));
  app.add_option("--tone-curve", tone_curve, "PNG only: filmic or clamp")->capture_default_str()->check(CLI::IsMember({"filmic", "clamp"}));
  app.add_flag("--no-aux", no_aux, "ignore the albedo and normal channels (denoise the colour alone)");
  app.add_option("--threads", threads, "denoiser threads (0: all cores)")->capture_default_str()->check(cli::integer(0, 4096));
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    std::fprintf(stderr, "lamina denoise: %s\n", cli::parse_error_line(e).c_str());
    return 2;
  }
  parse_tone_curve(tone_curve, &tone_map.curve);  // one of the two names (checked above)
  if (png_path.empty())
    for (const char* png_only : {"--exposure", "--tone-curve"})
      if (app.count(png_only) > 0) {  // it would not act: refused rather than ignored
        std::fprintf(stderr, "lamina denoise: %s is only meaningful with --png (the EXR stays linear)\n", png_only);
        return 2;
      }

  Image colour, albedo, normal;
  DenoiseInput input;
  Metadata metadata;
  DataWindow window;
  try {
    const std::vector<cli::OutputPath> outputs = {{"--out", out_path}, {"--png", png_path}};
    cli::check_output_paths(outputs);
    cli::check_outputs_not_inputs(outputs, {{"the input", in_path}});  // the raw render is never replaced
    const ChannelImage channels = read_channels(in_path);
    colour = channels.gather(in_path, "R", "G", "B");
    window = channels.window;  // a crop's denoised pixels stay where they were
    for (float v : colour.rgb)
      if (!std::isfinite(v)) throw cli::UsageError("'" + in_path + "' has non-finite colour values");
    const bool has_albedo = channels.find("albedo.R") >= 0, has_normal = channels.find("N.X") >= 0;
    if (!no_aux && has_albedo) {
      albedo = channels.gather(in_path, "albedo.R", "albedo.G", "albedo.B");
      input.albedo = &albedo;
      if (has_normal) {
        normal = channels.gather(in_path, "N.X", "N.Y", "N.Z");
        input.normal = &normal;
      }
    }
    if (!no_aux && !has_albedo)
      std::fprintf(stderr, "lamina denoise: warning: '%s' has no albedo AOV (render with --aovs albedo,normal): denoising the colour alone\n",
                   in_path.c_str());
    metadata = read_metadata(in_path);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "lamina denoise: %s\n", cli::one_line(e.what()).c_str());
    return 2;
  }
  input.colour = &colour;
  input.threads = threads;
  try {
    const auto t0 = std::chrono::steady_clock::now();
    const DenoiseResult r = denoise(input);
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    const std::string guides = input.normal ? "albedo, normal" : input.albedo ? "albedo" : "colour only";
    metadata.emplace_back("lamina:denoised", string_printf("Open Image Denoise %d.%d.%d RT filter, hdr, guided by %s; raw: %s",
                                                           r.version / 10000, r.version / 100 % 100, r.version % 100,
                                                           guides.c_str(), in_path.c_str()));
    cli::StagedOutputs outputs;
    outputs.write(out_path, [&](const std::string& tmp) { write_exr(tmp, r.image, metadata, {}, window); });
    if (!png_path.empty()) outputs.write(png_path, [&](const std::string& tmp) { write_png(tmp, tone_mapped(r.image, tone_map)); });
    outputs.commit();
    std::printf("lamina denoise: %s -> %s: %dx%d, guided by %s, %.2f s (Open Image Denoise %d.%d.%d from %s)\n", in_path.c_str(),
                out_path.c_str(), colour.width, colour.height, guides.c_str(), seconds, r.version / 10000, r.version / 100 % 100,
                r.version % 100, r.library.c_str());
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "lamina denoise: %s\n", cli::one_line(e.what()).c_str());
    return 1;
  }
}
