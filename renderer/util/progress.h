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
  // A time limit (--time-limit): the work stops `seconds` after the start, except the first
  // `committed_units`, which are done whatever the time (a render's first round). The ETA then
  // never promises more than the limit allows. Call before the first advance.
  void set_deadline(double seconds, std::uint64_t committed_units);
  // Ends the bar (newline on a terminal). Idempotent.
  void finish();
  double elapsed_seconds() const;

 private:
  void draw(bool final_draw);
  std::string label_;
  std::atomic<std::uint64_t> total_;
  double deadline_ = 0.0;  // seconds after start_; 0: none
  std::uint64_t committed_ = 0;
  std::string note_;
  std::atomic<std::uint64_t> done_{0};
  std::chrono::steady_clock::time_point start_;
  std::chrono::steady_clock::time_point last_draw_;
  std::mutex mutex_;
  bool tty_ = false;
  bool finished_ = false;
};

// The seconds left of work `done` of `total` units after `elapsed` seconds, at the rate so far;
// with a deadline (> 0, seconds from the start), no later than it, but no earlier than the
// `committed` units need (they are done whatever the time). Negative when unknown (nothing done).
double eta_seconds(double elapsed, std::uint64_t done, std::uint64_t total, double deadline, std::uint64_t committed);

// Peak resident set size of this process in bytes (getrusage), for the render summary.
std::uint64_t peak_memory_bytes();

}  // namespace lamina
