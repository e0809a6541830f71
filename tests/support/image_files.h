// Image files for tests, written and read with libraries other than the ones under test where
// that matters: stb_image_write for PNG and Radiance HDR inputs, stb_image to read back the
// bytes Lamina's libpng writer stored, OpenEXR for EXR inputs with chosen channels.
#pragma once

#include <string>
#include <vector>

namespace lamina::test {

// An 8-bit PNG of `channels` (1 grey, 2 grey+alpha, 3 RGB, 4 RGBA) interleaved bytes, untagged.
void write_png8(const std::string& path, int width, int height, int channels, const std::vector<unsigned char>& bytes);
// A Radiance RGBE file of width x height RGB floats.
void write_hdr(const std::string& path, int width, int height, const std::vector<float>& rgb);
// A float EXR with the given channel names, values interleaved per pixel in that order.
void write_exr_channels(const std::string& path, int width, int height, const std::vector<std::string>& names,
                        const std::vector<float>& values);
// An EXR's data window origin and display window size.
struct ExrWindows {
  int x = 0, y = 0, full_width = 0, full_height = 0;
};
ExrWindows read_exr_windows(const std::string& path);
// The stored 8-bit samples of a PNG (any channel count), as the file holds them; *channels and
// the sizes receive the file's. Empty if it cannot be decoded or is not 8-bit.
std::vector<unsigned char> read_png8(const std::string& path, int* width, int* height, int* channels);

}  // namespace lamina::test
