// The batch manifest reader (renderer/batch/manifest): parsing, validation and job expansion
// (which reads the files a manifest names; relative paths resolve against the seeds' folder).
#include "fuzz/fuzz_input.h"
#include "renderer/batch/batch_manifest.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string path = lamina::fuzz::input_file(data, size, ".json");
  return lamina::fuzz::refuse_cleanly([&] {
    const lamina::Manifest m = lamina::load_manifest(path);
    const std::vector<lamina::BatchJob> jobs = lamina::expand_jobs(m);
    lamina::resolve_comparisons(m, jobs);
  });
}
