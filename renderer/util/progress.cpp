// Progress reporting (see progress.h).
#include "renderer/util/progress.h"

#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>

namespace lamina {
namespace {

using Clock = std::chrono::steady_clock;

// Redraw a terminal bar at most 10 times a second; a log (stderr redirected to a file or a CI
// console) gets a line at most every 5 s, so a long render does not flood it.
constexpr double kTerminalInterval = 0.1;
constexpr double kLogInterval = 5.0;

std::string format_duration(double seconds) {
  char buffer[32];
  if (seconds < 60.0) {
    std::snprintf(buffer, sizeof buffer, "%.1fs", seconds);
  } else if (seconds < 3600.0) {
    const int s = static_cast<int>(seconds + 0.5);
    std::snprintf(buffer, sizeof buffer, "%dm%02ds", s / 60, s % 60);
  } else {
    const int m = static_cast<int>(seconds / 60.0 + 0.5);
    std::snprintf(buffer, sizeof buffer, "%dh%02dm", m / 60, m % 60);
  }
  return buffer;
}

}  // namespace

double eta_seconds(double elapsed, std::uint64_t done, std::uint64_t total, double deadline, std::uint64_t committed) {
  if (done == 0) return -1.0;
  const double per_unit = elapsed / static_cast<double>(done);
  const double remaining = static_cast<double>(total > done ? total - done : 0) * per_unit;
  if (!(deadline > 0.0)) return remaining;
  const double committed_left = static_cast<double>(committed > done ? committed - done : 0) * per_unit;
  return std::max(committed_left, std::min(remaining, std::max(deadline - elapsed, 0.0)));
}

Progress::Progress(std::string label, std::uint64_t total_units)
    : label_(std::move(label)),
      total_(total_units),
      start_(Clock::now()),
      last_draw_(start_),
      tty_(::isatty(STDERR_FILENO) != 0) {}

void Progress::advance(std::uint64_t units) {
  done_.fetch_add(units, std::memory_order_relaxed);
  // Whoever holds the lock draws; the others do not wait for it.
  std::unique_lock<std::mutex> lock(mutex_, std::try_to_lock);
  if (!lock.owns_lock() || finished_) return;
  const double since = std::chrono::duration<double>(Clock::now() - last_draw_).count();
  if (since >= (tty_ ? kTerminalInterval : kLogInterval)) draw(false);
}

void Progress::set_total(std::uint64_t total_units) { total_.store(total_units); }

void Progress::set_deadline(double seconds, std::uint64_t committed_units) {
  std::lock_guard<std::mutex> lock(mutex_);
  deadline_ = seconds;
  committed_ = committed_units;
}

void Progress::set_note(std::string note) {
  std::lock_guard<std::mutex> lock(mutex_);
  note_ = std::move(note);
}

void Progress::finish() {
  std::lock_guard<std::mutex> lock(mutex_);
  if (finished_) return;
  finished_ = true;
  draw(true);
}

double Progress::elapsed_seconds() const {
  return std::chrono::duration<double>(Clock::now() - start_).count();
}

// Called with mutex_ held.
void Progress::draw(bool final_draw) {
  last_draw_ = Clock::now();
  const double elapsed = elapsed_seconds();
  const std::uint64_t total = total_.load();
  const std::uint64_t done = std::min(done_.load(std::memory_order_relaxed), total);
  const double fraction = total > 0 ? static_cast<double>(done) / static_cast<double>(total) : 1.0;
  const std::string note = note_.empty() ? "" : "  " + note_;
  // ETA assuming the remaining units take as long on average as the finished ones (and the
  // deadline, if any, stops them).
  const double eta_s = eta_seconds(elapsed, done, total, deadline_, committed_);
  const std::string eta = eta_s >= 0.0 ? format_duration(eta_s) : "?";

  if (final_draw) {
    std::fprintf(stderr, "%s%s: %.0f%% in %s%s\n", tty_ ? "\r\033[K" : "", label_.c_str(), 100.0 * fraction,
                 format_duration(elapsed).c_str(), note.c_str());
  } else if (tty_) {
    constexpr int kWidth = 30;
    const int filled = static_cast<int>(fraction * kWidth);
    std::string bar(static_cast<std::size_t>(filled), '#');
    bar.resize(kWidth, '.');
    std::fprintf(stderr, "\r\033[K%s [%s] %5.1f%%  ETA %s%s", label_.c_str(), bar.c_str(), 100.0 * fraction,
                 eta.c_str(), note.c_str());
  } else {
    std::fprintf(stderr, "%s: %.1f%% (%s elapsed, ETA %s)%s\n", label_.c_str(), 100.0 * fraction,
                 format_duration(elapsed).c_str(), eta.c_str(), note.c_str());
  }
  std::fflush(stderr);
}

std::uint64_t peak_memory_bytes() {
  rusage usage{};
  if (::getrusage(RUSAGE_SELF, &usage) != 0) return 0;
  return static_cast<std::uint64_t>(usage.ru_maxrss) * 1024u;  // Linux reports kibibytes
}

}  // namespace lamina
