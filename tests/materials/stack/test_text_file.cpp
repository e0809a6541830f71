// Reading an input file says why it cannot be read (materials/stack/text_file.h).
#include <sys/stat.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include "materials/stack/text_file.h"

namespace lamina {
namespace {

namespace fs = std::filesystem;

TEST(TextFile, SaysWhyAFileCannotBeRead) {
  const fs::path dir = fs::path(::testing::TempDir()) / ("lamina_text_file_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  std::string text = "unchanged";
  EXPECT_EQ(read_text_file((dir / "missing.json").string(), &text), "does not exist");
  EXPECT_EQ(read_text_file((dir / "missing/x.json").string(), &text), "does not exist");
  EXPECT_EQ(read_text_file(dir.string(), &text), "is a directory, not a file");
  ASSERT_EQ(::mkfifo((dir / "fifo").c_str(), 0600), 0);
  EXPECT_EQ(read_text_file((dir / "fifo").string(), &text), "is not a regular file");  // and does not wait for a writer
  EXPECT_EQ(file_unreadable_reason(""), "does not exist (an empty path)");
  EXPECT_EQ(text, "unchanged");
  std::ofstream(dir / "ok.json") << "{\"a\": 1}";
  EXPECT_EQ(file_unreadable_reason((dir / "ok.json").string()), "");
  EXPECT_EQ(read_text_file((dir / "ok.json").string(), &text), "");
  EXPECT_EQ(text, "{\"a\": 1}");
  fs::remove_all(dir);
}

}  // namespace
}  // namespace lamina
