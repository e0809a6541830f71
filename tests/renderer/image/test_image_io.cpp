// Image files: round trips, metadata, atomic writes and clean errors on bad files.
#include "renderer/image/image_io.h"

#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "tests/support/image_files.h"

namespace fs = std::filesystem;
namespace lamina {
namespace {

// A fresh empty directory per test.
fs::path fresh_dir(const std::string& name) {
  fs::path dir = fs::path(::testing::TempDir()) / ("lamina_image_io_" + name);
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

std::vector<std::string> listing(const fs::path& dir) {
  std::vector<std::string> names;
  for (const auto& e : fs::directory_iterator(dir)) names.push_back(e.path().filename().string());
  return names;
}

Image test_pattern(int w, int h) {
  Image image(w, h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (int c = 0; c < 3; ++c)  // spans many binades, including 0 and values far above 1
        image.pixel(x, y)[c] = (x + 1) * std::pow(10.0f, static_cast<float>(y % 7) - 3.0f) * (c + 1) / 7.0f;
  image.pixel(0, 0)[0] = 0.0f;
  return image;
}

TEST(ImageIo, ExrRoundTripIsExactAndKeepsMetadata) {
  const fs::path dir = fresh_dir("exr_round_trip");
  const std::string path = (dir / "a.exr").string();
  const Image image = test_pattern(13, 9);
  const Metadata metadata = {{"lamina:spp", "64"}, {"lamina:settings", "--env 0.5 --seed 3"}};
  write_exr(path, image, metadata);
  EXPECT_EQ(listing(dir), std::vector<std::string>{"a.exr"});  // no temporary left behind

  const Image back = read_image(path);
  ASSERT_EQ(back.width, 13);
  ASSERT_EQ(back.height, 9);
  EXPECT_EQ(back.rgb, image.rgb);  // float EXR: bit exact

  const Metadata read = read_metadata(path);
  for (const auto& kv : metadata) {
    bool found = false;
    for (const auto& r : read) found |= (r == kv);
    EXPECT_TRUE(found) << kv.first;
  }
}

TEST(ImageIo, PngIsSrgbEncodedClampedAndDecodedOnRead) {
  const fs::path dir = fresh_dir("png");
  const std::string path = (dir / "a.png").string();
  Image image(64, 2);
  for (int x = 0; x < 64; ++x)
    for (int c = 0; c < 3; ++c) {
      image.pixel(x, 0)[c] = x / 63.0f;              // the whole [0, 1] range
      image.pixel(x, 1)[c] = c == 0 ? 2.0f : -1.0f;  // out of range: clamped
    }
  write_png(path, image);
  EXPECT_EQ(listing(dir), std::vector<std::string>{"a.png"});

  // The stored bytes are the sRGB encoding (IEC 61966-2-1): linear 0.5 encodes to
  // 1.055 * 0.5^(1/2.4) - 0.055 = 0.7354 -> byte round(187.5) = 188; pixel x = 63 * 0.5 is
  // not on the grid, so check x = 0 (0), x = 63 (255) and the clamped row.
  {
    int width = 0, height = 0, channels = 0;
    const std::vector<unsigned char> bytes = test::read_png8(path, &width, &height, &channels);
    ASSERT_EQ(bytes.size(), 64u * 2u * 3u) << "an 8-bit RGB PNG of 64 x 2";
    EXPECT_EQ(bytes[0], 0);
    EXPECT_EQ(bytes[63 * 3], 255);
    EXPECT_EQ(bytes[64 * 3 + 0], 255);  // 2.0 clamped
    EXPECT_EQ(bytes[64 * 3 + 1], 0);    // -1.0 clamped
    // x = 21: linear 1/3 encodes to 1.055 * (1/3)^(1/2.4) - 0.055 = 0.6125 -> byte round(156.19).
    EXPECT_EQ(bytes[21 * 3], 156);
  }
  const Image back = read_image(path);
  ASSERT_EQ(back.width, 64);
  // Quantisation to 8 bits moves the encoded value by at most 0.5/255; the decoding curve's
  // slope is at most 2.4/1.055 * 1^1.4 = 2.275 (at 1), so the linear error is below that times
  // 0.5/255.
  const double bound = 2.275 * 0.5 / 255.0 + 1e-6;
  for (int x = 0; x < 64; ++x)
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(back.pixel(x, 0)[c], x / 63.0, bound) << x;
  EXPECT_EQ(back.pixel(0, 1)[0], 1.0f);
  EXPECT_EQ(back.pixel(0, 1)[1], 0.0f);
}

TEST(ImageIo, GreyIsExpandedAndAlphaDropped) {
  const fs::path dir = fresh_dir("channels");
  // A one-channel 8-bit PNG of byte 128: decodes to ((128/255 + 0.055)/1.055)^2.4.
  const std::string grey = (dir / "grey.png").string();
  test::write_png8(grey, 2, 2, 1, {128, 128, 128, 128});
  const Image g = read_image(grey);
  const double expected = std::pow((128.0 / 255.0 + 0.055) / 1.055, 2.4);
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(g.pixel(1, 1)[c], expected, 1e-6);

  // An RGBA float EXR: alpha dropped, colours unchanged.
  const std::string rgba = (dir / "rgba.exr").string();
  test::write_exr_channels(rgba, 1, 1, {"R", "G", "B", "A"}, {0.25f, 3.5f, 0.125f, 0.5f});
  const Image a = read_image(rgba);
  EXPECT_EQ(a.pixel(0, 0)[0], 0.25f);
  EXPECT_EQ(a.pixel(0, 0)[1], 3.5f);
  EXPECT_EQ(a.pixel(0, 0)[2], 0.125f);
}

TEST(ImageIo, SixteenBitDataPngIsTaggedLinearAndReadBackAsStored) {
  // write_data_png16 tags the file linear (gAMA 1.0): read as the file says, no sRGB decoding,
  // every value back to 1/65535. An untagged 8-bit PNG (stb_image_write) is decoded from sRGB.
  const fs::path dir = fresh_dir("png16");
  const std::string path = (dir / "data.png").string();
  const std::vector<float> values = {0.0f, 0.25f, 0.5f, 0.999f, 1.0f, 1e-4f};
  write_data_png16(path, 3, 2, values);
  bool decoded = true;
  const Image back = read_image(path, StoredEncoding::kAsFile, &decoded);
  EXPECT_FALSE(decoded) << "a linear-tagged PNG is read as stored";
  for (int i = 0; i < 6; ++i)
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(back.rgb[i * 3 + c], values[i], 0.5 / 65535.0 + 1e-7) << i;
  const ChannelImage raw = read_channels(path);
  EXPECT_EQ(raw.names, std::vector<std::string>{"Y"});

  const std::string untagged = (dir / "untagged.png").string();
  test::write_png8(untagged, 1, 1, 3, {128, 128, 128});
  read_image(untagged, StoredEncoding::kAsFile, &decoded);
  EXPECT_TRUE(decoded) << "an untagged integer PNG is sRGB";
  EXPECT_FLOAT_EQ(read_channels(untagged).values[0], 128.0f / 255.0f);  // read_channels: stored values
}

TEST(ImageIo, RadianceHdrIsReadAsLinear) {
  // Radiance RGBE keeps an 8-bit mantissa per channel with a shared exponent: for channels within
  // a factor 2 of the largest the relative rounding error is below 2^-7.
  const fs::path dir = fresh_dir("hdr");
  const std::string path = (dir / "sky.hdr").string();
  const float px[3] = {3.0f, 2.5f, 1.75f};
  test::write_hdr(path, 1, 1, {px[0], px[1], px[2]});
  const Image back = read_image(path);
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(back.pixel(0, 0)[c], px[c], px[c] / 128.0) << c;
}

TEST(ImageIo, UnwritablePathThrowsNamingTheFileAndLeavesNothing) {
  const fs::path dir = fresh_dir("unwritable");
  const std::string missing_dir = (dir / "no_such_dir" / "out.exr").string();
  try {
    write_exr(missing_dir, test_pattern(4, 4));
    FAIL() << "expected ImageIoError";
  } catch (const ImageIoError& e) {
    EXPECT_NE(std::string(e.what()).find(missing_dir), std::string::npos) << e.what();
  }
  EXPECT_THROW(write_png((dir / "no_such_dir" / "out.png").string(), test_pattern(4, 4)), ImageIoError);
  EXPECT_TRUE(listing(dir).empty());

  // A failure after the temporary file is complete (the target is a directory, so rename(2)
  // fails) must remove the temporary file too.
  fs::create_directory(dir / "target.exr");
  EXPECT_THROW(write_exr((dir / "target.exr").string(), test_pattern(4, 4)), ImageIoError);
  EXPECT_EQ(listing(dir), std::vector<std::string>{"target.exr"});
  EXPECT_TRUE(fs::is_empty(dir / "target.exr"));
}

TEST(ImageIo, FailedWriteKeepsThePreviousFile) {
  const fs::path dir = fresh_dir("keep_previous");
  const std::string path = (dir / "a.exr").string();
  write_exr(path, test_pattern(5, 5));
  EXPECT_THROW(write_exr(path, Image()), ImageIoError);  // an empty image cannot be written
  EXPECT_EQ(read_image(path).rgb, test_pattern(5, 5).rgb);
}

TEST(ImageIo, TruncatedExrAndMissingFileGiveCleanErrors) {
  const fs::path dir = fresh_dir("truncated");
  const std::string good = (dir / "good.exr").string();
  write_exr(good, test_pattern(64, 64));
  std::ifstream in(good, std::ios::binary);
  std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  ASSERT_GT(bytes.size(), 400u);
  const std::string cut = (dir / "cut.exr").string();
  std::ofstream(cut, std::ios::binary).write(bytes.data(), static_cast<std::streamsize>(bytes.size() / 2));
  try {
    read_image(cut);
    FAIL() << "expected ImageIoError";
  } catch (const ImageIoError& e) {
    EXPECT_NE(std::string(e.what()).find(cut), std::string::npos) << e.what();
  }
  const std::string missing = (dir / "missing.exr").string();
  try {
    read_image(missing);
    FAIL() << "expected ImageIoError";
  } catch (const ImageIoError& e) {
    EXPECT_NE(std::string(e.what()).find(missing), std::string::npos) << e.what();
  }
  EXPECT_THROW(read_metadata(missing), ImageIoError);
}

}  // namespace
}  // namespace lamina
