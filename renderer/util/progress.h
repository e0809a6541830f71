// Progress for long work: a bar with ETA when stderr is a terminal, plain lines otherwise
// (at most every few seconds), and a closing summary line.
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <mutex>
#include <string>

namespace lamina {

class Progress {
 public:
  Progress(std::string label, std::uint64_t total_units);
  // Thread-safe; cheap enough to call once per tile.
  void advance(std::uint64_t units = 1);
  // A new total (adaptive sampling knows its work only after a first pass), and a short note
  // shown after the percentage (e.g. the converged fraction). Thread-safe.
  void set_total(std::uint64_t total_units);
  void set_note(std::string note);
  // Ends the bar (newline on a terminal). Idempotent.
  void finish();
  double elapsed_seconds() const;

 private:
  void draw(bool final_draw);
  std::string label_;
  std::atomic<std::uint64_t> total_;
  std::string note_;
  std::atomic<std::uint64_t> done_{0};
  std::chrono::steady_clock::time_point start_;
  std::chrono::steady_clock::time_point last_draw_;
  std::mutex mutex_;
  bool tty_ = false;
  bool finished_ = false;
};

// Peak resident set size of this process in bytes (getrusage), for the render summary.
std::uint64_t peak_memory_bytes();

}  // namespace lamina
