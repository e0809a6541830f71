// Every number an EXR header holds is finite, or nothing is written (docs/contracts.md,
// "Outputs"): write_exr refuses an attribute with a non-finite number, naming the file and the
// attribute, and leaves no file; the user's own words (names, paths, --meta) are not numbers.
#include <unistd.h>

#include <filesystem>
#include <string>

#include <gtest/gtest.h>

#include "renderer/image/image_io.h"
#include "renderer/util/finite_output.h"

namespace lamina {
namespace {

namespace fs = std::filesystem;

TEST(FiniteOutput, NonFiniteWordsInEverySpelling) {
  for (const char* w : {"nan", "-nan", "NaN", "inf", "-inf", "+inf", "infinity", "INF"}) EXPECT_TRUE(is_non_finite_token(w)) << w;
  for (const char* w : {"", "0", "1e308", "info", "infinite", "nano", "banana", "0x10", "1e999x"}) EXPECT_FALSE(is_non_finite_token(w)) << w;
  EXPECT_EQ(first_non_finite_word("0.1 0.2 nan +- 0.01 0.01 0.01"), "nan");
  EXPECT_EQ(first_non_finite_word("chose table (predicted error inf <= 0.05)"), "inf");
  EXPECT_EQ(first_non_finite_word("1,2,-nan(0x8000)"), "-nan");
  EXPECT_EQ(first_non_finite_word("the roughness 0.3 of the top interface: semi-infinite"), "");
  EXPECT_THROW(check_finite_output(0.0 / 0.0, "out.csv", "row x column y"), NonFiniteOutputError);
  try {
    check_finite_output(-1.0 / 0.0, "out.csv", "job1 seconds");
  } catch (const NonFiniteOutputError& e) {
    EXPECT_STREQ(e.what(), "out.csv: job1 seconds is not finite (-inf)");
  }
  EXPECT_NO_THROW(check_finite_output(1e308, "out.csv", "x"));
}

TEST(FiniteOutput, ExrHeaderNumbersAreFiniteOrNothingIsWritten) {
  const fs::path dir = fs::temp_directory_path() / ("lamina-finite-header-" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const std::string path = (dir / "x.exr").string();
  Image image(2, 2);
  const Metadata bad[] = {{{"lamina:seconds", "nan"}},
                          {{"lamina:similarity_bias:skin", "0.01 inf 0.02 +- 0.001 0.001 0.001"}},
                          {{"lamina:compare:guard_floor", "-nan"}},
                          {{"lamina:auto:skin", "chose table (predicted error nan <= 0.05)"}}};
  for (const Metadata& meta : bad) {
    try {
      write_exr(path, image, meta);
      ADD_FAILURE() << meta[0].first << " was written";
    } catch (const ImageIoError& e) {
      const std::string m = e.what();
      EXPECT_EQ(m.rfind(path + ": header attribute " + meta[0].first + " is not finite", 0), 0u) << m;
    }
    EXPECT_FALSE(fs::exists(path));
    EXPECT_EQ(std::distance(fs::directory_iterator(dir), fs::directory_iterator()), 0);  // no temporary either
  }
  // Names, paths and the user's --meta are words: a camera may be called "nan".
  const Metadata words = {{"lamina:camera", "nan"},           {"lamina:scene", "inf.gltf"}, {"lamina:command", "lamina render inf.gltf --camera nan"},
                          {"lamina:stack", "nan=skin.json"}, {"my_note", "inf"},           {"lamina:seconds", "0.25"}};
  EXPECT_NO_THROW(write_exr(path, image, words));
  EXPECT_EQ(read_metadata(path).size() >= words.size(), true);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace lamina
