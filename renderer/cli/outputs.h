// The output files of a subcommand (docs/contracts.md, "Command line: common rules"): every
// output path is checked before any work, and the outputs are written all or none.
//   - check_output_paths(): each path's directory exists and is writable, the path is not a
//     directory (nor a device or other non-regular file), and no two outputs are the same file.
//     Run before anything is read or computed, so a long computation never ends in a failed write.
//   - check_outputs_not_inputs(): no output is the same file as an input (links and relative paths
//     resolved), so that no option of any command overwrites what the command reads.
//   - StagedOutputs: each output is written to a temporary beside it (the one atomic writer,
//     renderer/util/atomic_file.h), and only when every one is written are they renamed over
//     their paths. A failed write removes every temporary, so the previous files stay as they
//     were and no new one appears; if a rename fails after others succeeded, the outputs already
//     renamed are removed: never some outputs of a run without the others.
// Header only: the lamina executable is the only user (renderer/cli/*.cpp).
#pragma once

#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "renderer/util/atomic_file.h"
#include "renderer/util/finite_output.h"
#include "renderer/util/paths.h"

namespace lamina::cli {

// One output: the option that names it (as printed in the error, e.g. "--png") and its path ("":
// not requested).
struct OutputPath {
  std::string option, path;
};

// Thrown by check_output_paths with one line naming the option and the path.
struct OutputPathError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

inline void check_output_path(const OutputPath& o) {
  namespace fs = std::filesystem;
  const fs::path p(o.path);
  const std::string what = o.option + " '" + o.path + "'";
  std::error_code ec;
  if (fs::is_directory(p, ec)) throw OutputPathError(what + " is a directory");
  if (fs::exists(p, ec) && !fs::is_regular_file(p, ec))
    throw OutputPathError(what + " exists and is not a regular file");
  const fs::path dir = p.has_parent_path() ? p.parent_path() : fs::path(".");
  if (!fs::is_directory(dir, ec))
    throw OutputPathError(what + ": directory '" + dir.string() + "' does not exist");
  if (::access(dir.c_str(), W_OK) != 0)
    throw OutputPathError(what + ": directory '" + dir.string() + "' is not writable");
}

// Checks every requested output (empty paths are skipped), then that no two name the same file.
inline void check_output_paths(const std::vector<OutputPath>& outputs) {
  namespace fs = std::filesystem;
  std::vector<std::pair<fs::path, const OutputPath*>> seen;
  for (const OutputPath& o : outputs) {
    if (o.path.empty()) continue;
    check_output_path(o);
    std::error_code ec;
    fs::path canonical = fs::weakly_canonical(fs::absolute(o.path, ec), ec);
    if (ec) canonical = fs::absolute(o.path).lexically_normal();
    for (const auto& [other, by] : seen)
      if (other == canonical)
        throw OutputPathError(o.option + " '" + o.path + "' is the same file as " + by->option + " '" + by->path + "'");
    seen.emplace_back(canonical, &o);
  }
}

// One input file of a command: how the message names it (e.g. "the input", "--materials") and its
// path ("": none).
struct InputPath {
  std::string what, path;
};

// Throws OutputPathError when an output names an existing input file: the same path, a symbolic
// or hard link to it, or another spelling of it (std::filesystem::equivalent compares the files
// themselves, renderer/util/paths.h). An output that does not exist yet cannot be an input that the command reads.
inline void check_outputs_not_inputs(const std::vector<OutputPath>& outputs, const std::vector<InputPath>& inputs) {
  for (const OutputPath& o : outputs) {
    if (o.path.empty()) continue;
    for (const InputPath& in : inputs) {
      if (in.path.empty()) continue;
      if (same_file(o.path, in.path))
        throw OutputPathError(o.option + " '" + o.path + "' is " + in.what + " '" + in.path +
                              "': an input is never overwritten");
    }
  }
}

// Throws NonFiniteOutputError("WHAT: JSON.PATH is not finite (VALUE)") at the first NaN or
// infinite number in `j` (nlohmann would write it as null), WHAT naming the output: every number
// a command writes is finite, or the command fails (docs/contracts.md, "Outputs"; the text
// formats' checks are renderer/util/finite_output.h). A null written on purpose (a fit's sigma that
// the data do not determine) is JSON null, not a number, and passes.
template <class Json>
void check_finite_numbers(const Json& j, const std::string& what, const std::string& path = "") {
  if (j.is_number_float()) {
    const double v = j.template get<double>();
    if (!std::isfinite(v))
      throw NonFiniteOutputError(non_finite_message(what, path.empty() ? "the value" : path, std::to_string(v)));
  } else if (j.is_object()) {
    for (auto it = j.begin(); it != j.end(); ++it) check_finite_numbers(it.value(), what, path.empty() ? it.key() : path + "." + it.key());
  } else if (j.is_array()) {
    for (std::size_t i = 0; i < j.size(); ++i) check_finite_numbers(j[i], what, path + "[" + std::to_string(i) + "]");
  }
}

class StagedOutputs {
 public:
  StagedOutputs() = default;
  StagedOutputs(const StagedOutputs&) = delete;
  StagedOutputs& operator=(const StagedOutputs&) = delete;
  ~StagedOutputs() { discard(); }

  // Calls writer(TMP), which must write the content of `path` to the file TMP (a fresh temporary
  // beside `path`). If it throws, every temporary of this set is removed and the error is thrown
  // again as std::runtime_error, with TMP replaced by `path` in its message.
  template <class Writer>
  void write(const std::string& path, Writer&& writer) {
    const std::string tmp = temporary_path(path);
    staged_.push_back({tmp, path});
    try {
      writer(tmp);
    } catch (const std::exception& e) {
      discard();
      throw std::runtime_error(replace_all(e.what(), tmp, path));
    }
  }

  // Renames every temporary over its path (fsync first). If one fails, the outputs renamed
  // before it are removed, the remaining temporaries too, and AtomicWriteError is thrown.
  void commit() {
    std::vector<std::string> done;
    for (std::size_t i = 0; i < staged_.size(); ++i) {
      try {
        commit_temporary(staged_[i].tmp, staged_[i].path);  // removes the temporary on failure
      } catch (...) {
        for (const std::string& p : done) std::remove(p.c_str());
        for (std::size_t j = i + 1; j < staged_.size(); ++j) std::remove(staged_[j].tmp.c_str());
        staged_.clear();
        throw;
      }
      done.push_back(staged_[i].path);
    }
    staged_.clear();
  }

  // Removes every temporary not yet committed.
  void discard() {
    for (const Staged& s : staged_) std::remove(s.tmp.c_str());
    staged_.clear();
  }

 private:
  static std::string replace_all(std::string s, const std::string& from, const std::string& to) {
    for (std::size_t at = s.find(from); at != std::string::npos; at = s.find(from, at + to.size()))
      s.replace(at, from.size(), to);
    return s;
  }

  struct Staged {
    std::string tmp, path;
  };
  std::vector<Staged> staged_;
};

}  // namespace lamina::cli
