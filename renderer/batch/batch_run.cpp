// lamina batch: renders the jobs of a manifest, compares them, and writes a contact sheet and a
// summary (docs/contracts.md, "lamina batch"; the manifest schema and outputs are in docs/batch.md).
//
// Every job runs in this process through render_job (renderer/render/render_job.h, the code path
// of `lamina render`), with the job's hash written into its EXR header; a job whose EXR exists
// and carries its hash is complete and is skipped, and since EXRs are written to a temporary file
// and renamed, a killed batch leaves no complete-looking output behind.
#include "renderer/batch/batch_run.h"

#include <unistd.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "renderer/batch/batch_manifest.h"
#include "renderer/image/contact_sheet.h"
#include "renderer/image/false_colour.h"
#include "renderer/image/image_compare.h"
#include "renderer/image/image_io.h"
#include "renderer/image/tone_map.h"
#include "renderer/render/render_job.h"
#include "renderer/render/spectral_option.h"
#include "renderer/render/walk_option_table.h"
#include "renderer/util/atomic_file.h"
#include "renderer/util/finite_output.h"
#include "renderer/util/paths.h"
#include "renderer/util/progress.h"
#include "renderer/util/string_format.h"

namespace lamina {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

std::string job_exr(const std::string& out, const BatchJob& job) { return (fs::path(out) / "jobs" / (job.id + ".exr")).string(); }

// A file name for a glTF material name (any UTF-8 string): unsafe bytes become '_'.
std::string file_stem_for(const std::string& name) {
  std::string s;
  for (unsigned char c : name) s += (std::isalnum(c) || c == '-' || c == '.') ? static_cast<char>(c) : '_';
  if (s.empty() || s[0] == '.') s = "_" + s;
  return s;
}

// Writes `text` to `path` unless the file already holds exactly that, atomically
// (renderer/util/atomic_file.h), so shards running at once on a shared file system never see a
// half-written file.
void write_text_if_changed(const std::string& path, const std::string& text) {
  {
    std::ifstream in(path, std::ios::binary);
    if (in) {
      std::ostringstream s;
      s << in.rdbuf();
      if (s.str() == text) return;
    }
  }
  try {
    write_file_atomically(path, text);
  } catch (const AtomicWriteError& e) {
    throw BatchError(path + ": cannot write (" + e.reason + ")");
  }
}

// A job is complete when its EXR exists, its header carries the job's hash and is not a preview
// (lamina:preview: the image so far of a render that did not finish), and every pixel reads: a
// header with the hash in front of truncated or damaged pixels is not a finished job.
bool job_complete(const std::string& out, const BatchJob& job, Metadata* metadata = nullptr) {
  const std::string path = job_exr(out, job);
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) return false;
  try {
    Metadata meta = read_metadata(path);
    bool hash = false, preview = false;
    for (const auto& [k, v] : meta) {
      hash = hash || (k == "lamina:job_hash" && v == job.hash);
      preview = preview || k == "lamina:preview";
    }
    if (!hash || preview) return false;
    read_channels(path);  // throws when a pixel cannot be read
    if (metadata) *metadata = std::move(meta);
    return true;
  } catch (const std::exception&) {
  }
  return false;
}

// The material map of a job (glTF material name -> stack file, relative to the map), with the
// stacks written beside it: out/materials/<scene>/<variant>/. `stacks` receives the same stacks
// in memory, named by their files.
// Where they go: the map, and each material's stack file (job.materials' order).
struct MaterialRecord {
  std::string map;
  std::vector<std::string> stems;  // "<stem>.json" beside the map
  std::vector<std::string> stacks;
};
MaterialRecord material_record(const std::string& out, const BatchJob& job) {
  const fs::path dir = fs::path(out) / "materials" / job.scene / job.variant;
  MaterialRecord r{(dir / "map.json").string(), {}, {}};
  std::set<std::string> stems;
  for (const MaterialBinding& b : job.materials) {
    std::string stem = file_stem_for(b.material);
    for (int k = 2; stems.count(stem); ++k) stem = file_stem_for(b.material) + "-" + std::to_string(k);
    stems.insert(stem);
    r.stems.push_back(stem);
    r.stacks.push_back((dir / (stem + ".json")).string());
  }
  return r;
}

std::string write_material_map(const std::string& out, const BatchJob& job, std::vector<InlineStack>* stacks) {
  const MaterialRecord record = material_record(out, job);
  fs::create_directories(fs::path(record.map).parent_path());
  const std::string& map_path = record.map;
  json map = json::object();
  for (std::size_t i = 0; i < job.materials.size(); ++i) {
    const MaterialBinding& b = job.materials[i];
    const std::string& stem = record.stems[i];
    const std::string& stack_path = record.stacks[i];
    const std::string text = b.stack.dump(2) + "\n";
    write_text_if_changed(stack_path, text);
    // Named as `lamina render --materials` names it: relative to the map.
    stacks->push_back({b.material, text, resolve_relative_to(stem + ".json", map_path)});
    map[b.material] = stem + ".json";
  }
  write_text_if_changed(map_path, map.dump(2) + "\n");
  return map_path;
}

std::string number(double v) { return string_printf("%.17g", v); }

// Renders one job in-process through render_job (the code path of `lamina render`). Its
// lamina:command is the `lamina render` command line that renders the same image from the
// files this batch writes (the variant stacks' material map). Returns the result, or nothing
// (the error printed) if the render failed.
std::optional<RenderResult> render_batch_job(const std::string& out, const BatchJob& job, const Manifest& m, int threads,
                                             const BatchLog& log) {
  RenderRequest r;
  r.scene_path = job.scene_file;
  r.out_path = job_exr(out, job);
  r.settings.spp = job.spp;
  r.settings.width = m.settings.width;
  r.settings.height = m.settings.height;
  r.settings.seed = m.settings.seed;
  r.settings.max_depth = m.settings.max_depth;
  r.settings.threads = threads;
  r.subsurface = job.subsurface;
  std::vector<std::string> args = {"render", job.scene_file, "-o", r.out_path,
                                   "--spp", std::to_string(job.spp), "--width", std::to_string(m.settings.width),
                                   "--height", std::to_string(m.settings.height), "--seed", std::to_string(m.settings.seed),
                                   "--max-depth", std::to_string(m.settings.max_depth), "--subsurface", job.subsurface.name(),
                                   "--threads", std::to_string(threads)};
  if (job.subsurface.automatic) args.insert(args.end(), {"--tolerance", number(job.subsurface.tolerance)});
  // The walk's options as `lamina render` takes them (none while a batch keeps the defaults).
  const std::vector<std::string> walk_args = walk_option_arguments(r.walk);
  args.insert(args.end(), walk_args.begin(), walk_args.end());
  if (!job.env.empty()) {
    r.env = job.env;
    args.insert(args.end(), {"--env", job.env});
  }
  if (!job.camera.empty()) {
    r.camera_name = job.camera;
    args.insert(args.end(), {"--camera", job.camera});
  }
  for (const StackAssignment& a : job.stacks) args.insert(args.end(), {kStackFlag, stack_assignment_text(a)});
  r.stacks = job.stacks;
  if (job.spectral) {
    r.settings.spectral = true;
    args.push_back(kSpectralOption.flag);
    r.given.push_back(kSpectralOption.flag);
  }
  if (!job.materials.empty()) {
    // The stacks are rendered from memory; the files are the record (docs/batch.md).
    const std::string map_path = write_material_map(out, job, &r.inline_stacks);
    args.insert(args.end(), {"--materials", map_path});
  }
  // Tables, auto predictions and lambert albedos are shared by every job (and shard) of the
  // batch whose stack and build match (renderer/layered/walk_cache.h): each is computed once.
  r.cache_dir = (fs::path(out) / "cache").string();
  args.insert(args.end(), {"--cache", r.cache_dir});
  r.extra_metadata = {{"lamina:job_id", job.id}, {"lamina:job_hash", job.hash}};
  args.insert(args.end(), {"--meta", "lamina:job_id=" + job.id, "--meta", "lamina:job_hash=" + job.hash});
  r.command_line = "lamina";
  for (const std::string& a : args) r.command_line += " " + a;
  try {
    RenderResult result = render_job(r, log.render);
    if (log.render_summary) log.render_summary(r, result);
    return result;
  } catch (const std::exception& e) {
    if (log.render_error) log.render_error(e.what());
    return std::nullopt;
  }
}

// Temporary files left by a killed write ("<file>.tmp-<host>-<pid>-<n>",
// renderer/util/atomic_file.h): only removed when no other process can be writing them.
void remove_stale_temporaries(const std::string& out) {
  for (const char* sub : {"jobs", "diffs", "cache/tables", "cache/auto", "cache/albedo"}) {
    std::error_code ec;
    const fs::path dir = fs::path(out) / sub;
    if (!fs::is_directory(dir, ec)) continue;
    for (const fs::directory_entry& e : fs::directory_iterator(dir, ec))
      if (e.path().filename().string().find(".tmp-") != std::string::npos) fs::remove(e.path(), ec);
  }
}

std::string meta_value(const Metadata& meta, const std::string& key) {
  for (const auto& [k, v] : meta)
    if (k == key) return v;
  return "";
}

// What `--subsurface auto` chose per material, from the EXR header: `lamina render` writes
// "lamina:auto_mode:<glTF material name>" = random-walk | first-order | table | lambert |
// lambert-hidden (not seen by camera rays, not predicted). Files written before that header
// existed have only the reason, "lamina:auto:<material>" = "chose <mode> (predicted error ...)"
// or "not visible to camera rays: ...", which is read instead. Sorted by material name (the
// metadata's order is the file's). Empty for fixed-mode jobs.
struct AutoChoiceEntry {
  std::string material, mode;
};
std::vector<AutoChoiceEntry> auto_choices(const Metadata& meta) {
  const std::string mode_prefix = "lamina:auto_mode:", reason_prefix = "lamina:auto:";
  std::vector<AutoChoiceEntry> out;
  for (const auto& [k, v] : meta)
    if (k.compare(0, mode_prefix.size(), mode_prefix) == 0) out.push_back({k.substr(mode_prefix.size()), v});
  if (out.empty())
    for (const auto& [k, v] : meta) {
      if (k.compare(0, reason_prefix.size(), reason_prefix) != 0) continue;
      std::string mode;
      if (v.compare(0, 6, "chose ") == 0) {
        mode = v.substr(6, v.find(' ', 6) == std::string::npos ? std::string::npos : v.find(' ', 6) - 6);
      } else if (v.compare(0, 11, "not visible") == 0) {
        mode = kHiddenAutoModeName;
      } else {
        mode = "?";  // a reason this version does not know how to read
      }
      out.push_back({k.substr(reason_prefix.size()), mode});
    }
  std::sort(out.begin(), out.end(), [](const AutoChoiceEntry& a, const AutoChoiceEntry& b) { return a.material < b.material; });
  return out;
}

// "skin=first-order;leaf=random-walk".
std::string auto_choices_text(const std::vector<AutoChoiceEntry>& choices) {
  std::string s;
  for (const AutoChoiceEntry& c : choices) s += (s.empty() ? "" : ";") + c.material + "=" + c.mode;
  return s;
}

// A CSV field (RFC 4180): quoted when it holds a comma, a quote or a line break (material names
// are arbitrary glTF strings).
std::string csv_field(const std::string& s) {
  if (s.find_first_of(",\"\r\n") == std::string::npos) return s;
  std::string q = "\"";
  for (char c : s) q += c == '"' ? std::string("\"\"") : std::string(1, c);
  return q + "\"";
}

// A short form of a mode for a contact sheet label, where a cell is ~160 px wide.
std::string short_mode(const std::string& name) {
  SubsurfaceMode mode;
  return parse_subsurface_mode(name, &mode) ? subsurface_mode_short_name(mode) : name;
}

// A job's axes as labels show them, in job-id order (scene, variant, lighting, mode, spp), and
// those of `shown` joined as a job cell's label is: "head / base / default, random-walk, 16 spp".
constexpr std::size_t kJobAxes = 5;
std::string axes_text(const BatchJob& job, const std::array<bool, kJobAxes>& shown) {
  const std::array<std::string, kJobAxes> axes = {job.scene, job.variant, job.lighting, job.mode, std::to_string(job.spp) + " spp"};
  std::string s;
  for (std::size_t k = 0; k < kJobAxes; ++k)
    if (shown[k]) s += (s.empty() ? "" : k < 3 ? " / " : ", ") + axes[k];
  return s;
}

// The picture of a comparison, written to `png`, and its contact-sheet cell. They show the
// difference's pattern, not the renders' noise: both images smoothed as `lamina compare --smooth`
// does (the metrics and the EXR stay per pixel). The legend names both jobs; the cell names the
// comparison, range and smoothing, the axes both jobs share, and REF and TEST by the axes they
// differ in.
ContactCell write_difference_picture(const std::string& png, const ContactSheetSpec& sheet, const std::string& name,
                                     const BatchJob& ref_job, const BatchJob& test_job, const Image& ref, const Image& test) {
  const double range = sheet.diff_range, sigma = sheet.diff_smooth;
  const ImagePair shown = smoothed_pair(ref, test, sigma);
  const std::vector<float> rel = relative_luminance_difference(shown.reference, shown.test);
  const std::array<bool, kJobAxes> all = {true, true, true, true, true};
  write_png(png, false_colour_with_legend(rel, ref.width, ref.height, range, difference_caption(sigma),
                                          {"REF: " + axes_text(ref_job, all), "TEST: " + axes_text(test_job, all)}));
  const std::array<bool, kJobAxes> differ = {ref_job.scene != test_job.scene, ref_job.variant != test_job.variant,
                                       ref_job.lighting != test_job.lighting, ref_job.mode != test_job.mode,
                                       ref_job.spp != test_job.spp};
  std::array<bool, kJobAxes> same;
  for (std::size_t k = 0; k < kJobAxes; ++k) same[k] = !differ[k];
  std::vector<std::string> label = {
      "diff " + name, string_printf("+-%g%%, ", 100.0 * range) + (sigma > 0.0 ? string_printf("sigma %g px", sigma) : "per pixel")};
  if (const std::string shared = axes_text(test_job, same); !shared.empty()) label.push_back(shared);
  label.insert(label.end(), {"REF " + axes_text(ref_job, differ), "TEST " + axes_text(test_job, differ)});
  return {false_colour_map(rel, ref.width, ref.height, range), std::move(label)};
}

// Shortest text that reads back as the same double (nlohmann::json prints numbers so). A number
// that is not finite fails the batch naming the file, the row and the column, before the file is
// written (renderer/util/finite_output.h); an empty column is written on purpose, for a value
// that does not exist (no comparison, no timing in the header).
std::string csv_number(double v, const std::string& file, const std::string& row, const std::string& column) {
  try {
    check_finite_output(v, file, row + " " + column);
  } catch (const NonFiniteOutputError& e) {
    throw BatchError(e.what());
  }
  return json(v).dump();
}
std::string csv_number(const std::optional<double>& v, const std::string& file, const std::string& row, const std::string& column) {
  return v ? csv_number(*v, file, row, column) : "";
}

// Comparisons, previews, the contact sheet and the summary: needs every job complete.
int finalize(const std::string& out, const Manifest& m, const std::vector<BatchJob>& jobs, const std::vector<ComparisonPair>& pairs,
             const std::map<std::size_t, std::vector<MaterialModeChoice>>& rendered_choices, const BatchLog& log) {
  // What auto chose per job: this process's render results, else the EXR header.
  auto choices_of = [&](const BatchJob& job, const Metadata& header) {
    const auto it = rendered_choices.find(job.index);
    if (it == rendered_choices.end()) return auto_choices(header);
    std::vector<AutoChoiceEntry> c;
    for (const MaterialModeChoice& x : it->second) c.push_back({x.material, x.mode});
    std::sort(c.begin(), c.end(), [](const AutoChoiceEntry& a, const AutoChoiceEntry& b) { return a.material < b.material; });
    return c;
  };
  std::vector<Metadata> meta(jobs.size());
  std::vector<std::string> missing;
  for (const BatchJob& job : jobs)
    if (!job_complete(out, job, &meta[job.index])) missing.push_back(job.id);
  if (!missing.empty())
    throw BatchError(std::to_string(missing.size()) + " of " + std::to_string(jobs.size()) + " jobs have no complete output in '" + out +
                     "' (first: " + missing.front() + "); render them first (all shards)");
  remove_stale_temporaries(out);
  fs::create_directories(fs::path(out) / "diffs");

  std::vector<Image> images;
  images.reserve(jobs.size());
  for (const BatchJob& job : jobs) {
    images.push_back(read_image(job_exr(out, job)));
    write_png((fs::path(out) / "jobs" / (job.id + ".png")).string(), tone_mapped(images.back(), m.contact_sheet.tone_map));
  }

  // Comparisons: the difference images and their metrics.
  std::vector<CompareMetrics> metrics(pairs.size());
  std::vector<ContactCell> diff_cells;
  std::ostringstream cmp_csv;
  cmp_csv << "comparison,reference,test,mean_relative,rms_relative,max_abs_relative,rmse,ssim\n";
  for (std::size_t i = 0; i < pairs.size(); ++i) {
    const ComparisonPair& p = pairs[i];
    const Image& ref = images[p.reference];
    const Image& test = images[p.test];
    if (ref.width != test.width || ref.height != test.height) throw BatchError(p.id + ": the two images differ in size");
    metrics[i] = compare_images(ref, test);
    const CompareMetrics& c = metrics[i];
    const std::string stem = (fs::path(out) / "diffs" / p.id).string();
    write_exr(stem + ".exr", relative_difference(ref, test, c.guard_floor),
              {{"lamina:compare:reference", jobs[p.reference].id},
               {"lamina:compare:test", jobs[p.test].id},
               {"lamina:compare:definition", "(TEST - REF) / max(REF, guard_floor)"},
               {"lamina:compare:guard_floor", number(c.guard_floor)}});
    diff_cells.push_back(write_difference_picture(stem + ".png", m.contact_sheet, p.name, jobs[p.reference], jobs[p.test], ref, test));
    const std::string cmp_file = (fs::path(out) / "comparisons.csv").string();
    auto cmp_number = [&](double v, const char* column) { return csv_number(v, cmp_file, p.id, column); };
    cmp_csv << p.name << "," << jobs[p.reference].id << "," << jobs[p.test].id << "," << cmp_number(c.mean_relative, "mean_relative")
            << "," << cmp_number(c.rms_relative, "rms_relative") << "," << cmp_number(c.max_abs_relative, "max_abs_relative") << ","
            << cmp_number(c.rmse, "rmse") << "," << cmp_number(c.ssim, "ssim") << "\n";
  }
  write_text_if_changed((fs::path(out) / "comparisons.csv").string(), cmp_csv.str());

  // The summary: one row per job; the error columns hold the first comparison the job is the
  // test of, and are empty for jobs that are no comparison's test.
  std::ostringstream csv;
  csv << "job,scene,variant,lighting,mode,spp,seconds,rays_per_second,rmse_vs_reference,rel_rms_vs_reference,auto_choices\n";
  for (const BatchJob& job : jobs) {
    const Metadata& mt = meta[job.index];
    // Timings from the header; a header without them (or a render of no measurable time) leaves
    // the columns empty.
    std::optional<double> seconds, rays_per_second;
    try {
      const double s = std::stod(meta_value(mt, "lamina:seconds"));
      const double rays = std::stod(meta_value(mt, "lamina:rays_closest")) + std::stod(meta_value(mt, "lamina:rays_shadow"));
      seconds = s;
      if (s > 0.0) rays_per_second = rays / s;
    } catch (const std::exception&) {
    }
    const std::string summary_file = (fs::path(out) / "summary.csv").string();
    csv << job.id << "," << job.scene << "," << job.variant << "," << job.lighting << "," << job.mode << "," << job.spp << ","
        << csv_number(seconds, summary_file, job.id, "seconds") << ","
        << csv_number(rays_per_second, summary_file, job.id, "rays_per_second") << ",";
    const auto it = std::find_if(pairs.begin(), pairs.end(), [&](const ComparisonPair& p) { return p.test == job.index; });
    if (it != pairs.end()) {
      const CompareMetrics& c = metrics[static_cast<std::size_t>(it - pairs.begin())];
      csv << csv_number(c.rmse, summary_file, job.id, "rmse_vs_reference") << ","
          << csv_number(c.rms_relative, summary_file, job.id, "rel_rms_vs_reference");
    } else {
      csv << ",";
    }
    csv << "," << csv_field(auto_choices_text(choices_of(job, mt))) << "\n";
  }
  write_text_if_changed((fs::path(out) / "summary.csv").string(), csv.str());

  // Contact sheet: every job, then every difference.
  std::vector<ContactCell> cells;
  for (const BatchJob& job : jobs) {
    // An auto job's label names what it chose: "auto-0.05 (skin 1st, leaf walk), 64 spp".
    std::string mode = job.mode;
    const std::vector<AutoChoiceEntry> chosen = choices_of(job, meta[job.index]);
    if (!chosen.empty()) {
      std::string brief;
      for (const AutoChoiceEntry& c : chosen) brief += (brief.empty() ? "" : ", ") + (chosen.size() > 1 ? c.material + " " : "") + short_mode(c.mode);
      mode += " (" + brief + ")";
    }
    cells.push_back({tone_mapped(images[job.index], m.contact_sheet.tone_map), {job.scene + " / " + job.variant + " / " + job.lighting, mode + ", " + std::to_string(job.spp) + " spp"}});
  }
  for (ContactCell& c : diff_cells) cells.push_back(std::move(c));
  bool labelled = true;
  const Image sheet = make_contact_sheet(cells, m.contact_sheet.columns, m.contact_sheet.thumbnail_width, &labelled);
  if (!labelled) log.err("lamina batch: warning: DejaVu Sans not found (fonts-dejavu-core): contact sheet without labels");
  write_png((fs::path(out) / "contact_sheet.png").string(), sheet);
  log.out(string_printf("lamina batch: %s: %zu images, %zu comparisons, contact_sheet.png, summary.csv", out.c_str(), jobs.size(), pairs.size()));
  return 0;
}

// No file the batch writes is one it reads: the manifest, or a file a job reads (BatchJob::inputs:
// its scene and the buffers and images that names, its stacks, its environment map), under any
// name (renderer/util/paths.h's same_file: links and other spellings resolved).
void check_outputs_not_inputs(const std::string& out, const std::string& manifest, const std::vector<BatchJob>& jobs) {
  // What the message names each input by (its path included), and the path.
  std::vector<std::pair<std::string, std::string>> inputs = {{"the manifest '" + manifest + "'", manifest}};
  for (const BatchJob& job : jobs)
    for (const JobInput& in : job.inputs) inputs.push_back({in.what + " '" + in.path + "' (job " + job.id + ")", in.path});
  std::vector<std::string> outputs;
  for (const char* name : {"jobs.json", "summary.csv", "comparisons.csv", "contact_sheet.png"})
    outputs.push_back((fs::path(out) / name).string());
  for (const BatchJob& job : jobs) {
    outputs.push_back(job_exr(out, job));
    outputs.push_back((fs::path(out) / "jobs" / (job.id + ".png")).string());
    if (job.materials.empty()) continue;
    const MaterialRecord record = material_record(out, job);  // the variant's stacks, written before the job renders
    outputs.push_back(record.map);
    outputs.insert(outputs.end(), record.stacks.begin(), record.stacks.end());
  }
  for (const std::string& o : outputs)
    for (const auto& [what, path] : inputs)
      if (same_file(o, path))
        throw BatchUsageError("--out '" + out + "': the output '" + o + "' is " + what + ": an input is never overwritten");
}

}  // namespace

int run_batch_manifest(const BatchOptions& args, const BatchLog& log) {
  int shard = 0, shard_count = 1;
  if (!args.shard.empty()) {
    try {
      std::tie(shard, shard_count) = parse_shard(args.shard);
    } catch (const std::invalid_argument& e) {
      throw BatchUsageError(e.what());
    }
  }
  const Manifest m = load_manifest(args.manifest);
  const std::vector<BatchJob> jobs = expand_jobs(m);
  const std::vector<ComparisonPair> pairs = resolve_comparisons(m, jobs);
  const std::string out = args.out.empty() ? fs::path(args.manifest).stem().string() + "-batch" : args.out;

  if (args.list) {
    for (const BatchJob& job : jobs)
      if (in_shard(job.index, shard, shard_count)) log.out(string_printf("%zu %s %s", job.index, job.id.c_str(), job.hash.c_str()));
    return 0;
  }

  check_outputs_not_inputs(out, args.manifest, jobs);
  std::error_code ec;
  fs::create_directories(fs::path(out) / "jobs", ec);
  if (ec || !fs::is_directory(fs::path(out) / "jobs")) throw BatchUsageError("--out '" + out + "': cannot create the directory");
  if (::access(out.c_str(), W_OK) != 0) throw BatchUsageError("--out '" + out + "': the directory is not writable");
  // A record of the expansion: what each job is and its hash.
  json record = json::array();
  for (const BatchJob& job : jobs) record.push_back({{"id", job.id}, {"hash", job.hash}, {"description", job.description}});
  write_text_if_changed((fs::path(out) / "jobs.json").string(), record.dump(2) + "\n");

  // What auto chose in the jobs rendered by this process, from their results; jobs rendered
  // earlier (or by other shards) have it only in their EXR header.
  std::map<std::size_t, std::vector<MaterialModeChoice>> rendered_choices;
  if (!args.finalize) {
    if (shard_count == 1) remove_stale_temporaries(out);
    std::vector<const BatchJob*> mine;
    for (const BatchJob& job : jobs)
      if (in_shard(job.index, shard, shard_count)) mine.push_back(&job);
    std::size_t rendered = 0, skipped = 0;
    std::vector<std::string> failed;
    Progress progress("batch", mine.size());
    for (std::size_t k = 0; k < mine.size(); ++k) {
      const BatchJob& job = *mine[k];
      if (!args.force && job_complete(out, job)) {
        ++skipped;
        log.out(string_printf("lamina batch: [%zu/%zu] %s: complete, skipped", k + 1, mine.size(), job.id.c_str()));
      } else {
        log.out(string_printf("lamina batch: [%zu/%zu] %s: rendering", k + 1, mine.size(), job.id.c_str()));
        const std::optional<RenderResult> result = render_batch_job(out, job, m, args.threads, log);
        if (result && job_complete(out, job)) {
          ++rendered;
          rendered_choices[job.index] = result->auto_choices;
        } else {
          failed.push_back(job.id);
          log.err(string_printf("lamina batch: job %s failed (status %d)", job.id.c_str(), result ? 0 : 1));
        }
      }
      progress.advance();
    }
    progress.finish();
    log.out(string_printf("lamina batch: %s%zu jobs: %zu rendered, %zu already complete, %zu failed",
                   shard_count > 1 ? ("shard " + args.shard + ": ").c_str() : "", mine.size(), rendered, skipped, failed.size()));
    if (!failed.empty()) {
      log.err(string_printf("lamina batch: %zu job(s) failed (first: %s); rerun to retry them", failed.size(), failed.front().c_str()));
      return 1;
    }
    if (shard_count > 1) return 0;  // comparisons and the sheet: `--finalize` once every shard is done
  }
  return finalize(out, m, jobs, pairs, rendered_choices, log);
}


}  // namespace lamina
