// Progress: thread-safe counting, one closing line, peak memory.
#include "renderer/util/progress.h"

#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

namespace lamina {
namespace {

int count(const std::string& text, const std::string& what) {
  int n = 0;
  for (std::size_t at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) ++n;
  return n;
}

TEST(Progress, ConcurrentAdvancesReachTotalAndFinishPrintsOnce) {
  ::testing::internal::CaptureStderr();  // stderr is then a file: plain-line mode
  {
    Progress progress("tiles", 4 * 5000);
    std::vector<std::thread> threads;
    for (int t = 0; t < 4; ++t)
      threads.emplace_back([&] {
        for (int i = 0; i < 5000; ++i) progress.advance();
      });
    for (auto& t : threads) t.join();
    progress.finish();
    progress.finish();  // idempotent
    EXPECT_GE(progress.elapsed_seconds(), 0.0);
  }
  const std::string out = ::testing::internal::GetCapturedStderr();
  // Far less than 5 s passed, so the only line is the closing one, at 100% (all 20000 units
  // were counted despite the concurrent advances).
  EXPECT_EQ(count(out, "\n"), 1) << out;
  EXPECT_EQ(count(out, "tiles: 100% in "), 1) << out;
}

TEST(Progress, ZeroTotalDoesNotDivideByZero) {
  ::testing::internal::CaptureStderr();
  Progress progress("empty", 0);
  progress.finish();
  const std::string out = ::testing::internal::GetCapturedStderr();
  EXPECT_EQ(count(out, "empty: 100% in "), 1) << out;
}

TEST(Progress, EtaIsTheRateTimesTheUnitsLeft) {
  EXPECT_LT(eta_seconds(1.0, 0, 100, 0.0, 0), 0.0);  // nothing done: unknown
  EXPECT_DOUBLE_EQ(eta_seconds(2.0, 25, 100, 0.0, 0), 6.0);
  EXPECT_DOUBLE_EQ(eta_seconds(2.0, 100, 100, 0.0, 0), 0.0);
}

// A time limit of 30 s on work whose rate alone would take 10 minutes: the ETA is what is left of
// the 30 s; once the limit has passed, what the committed first round still needs.
TEST(Progress, EtaFollowsTheDeadlineAndTheCommittedRound) {
  EXPECT_DOUBLE_EQ(eta_seconds(10.0, 10, 610, 30.0, 5), 20.0);
  EXPECT_DOUBLE_EQ(eta_seconds(10.0, 10, 12, 30.0, 5), 2.0);   // ends before the limit
  EXPECT_DOUBLE_EQ(eta_seconds(40.0, 10, 610, 30.0, 5), 0.0);  // past it, the round done
  EXPECT_DOUBLE_EQ(eta_seconds(40.0, 10, 610, 30.0, 20), 40.0);  // past it, 10 units of the round left
}

TEST(Progress, PeakMemoryCoversATouchedAllocation) {
  constexpr std::size_t kBytes = 64u << 20;
  std::vector<char> block(kBytes, 1);  // value-initialised: every page touched
  EXPECT_GE(peak_memory_bytes(), kBytes);
  EXPECT_EQ(block[kBytes - 1], 1);
}

}  // namespace
}  // namespace lamina
