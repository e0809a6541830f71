// Image files: linear float EXR with metadata (OpenEXR), sRGB PNG previews and 16-bit data maps
// (libpng), and reading EXR, Radiance HDR and the integer formats PNG, JPEG, BMP, GIF, PNM
// (stb_image): environment maps, parameter maps, textures for `lamina fit`, `lamina compare`.
#pragma once

#include <stdexcept>
#include <cstddef>
#include <string>
#include <utility>
#include <vector>

#include "renderer/image/image.h"

namespace lamina {

// Thrown with a one-line message that names the file and the problem.
struct ImageIoError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

using Metadata = std::vector<std::pair<std::string, std::string>>;  // EXR header attributes

// Writes a linear RGB half/float EXR atomically: to a temporary file beside `path`, then
// rename(2), so a failed or killed write never leaves a half-written `path`.
void write_exr(const std::string& path, const Image& image, const Metadata& metadata = {});
// The same with more float channels after R, G, B (e.g. adaptive sampling's per-pixel sample
// count): each a name and width * height values, row major.
struct ExtraChannel {
  std::string name;
  std::vector<float> values;
};
// Where the pixels sit in a larger image (a crop): the EXR's data window starts at (x, y) of a
// display window full_width x full_height. full_width 0: the image is the whole.
struct DataWindow {
  int x = 0, y = 0, full_width = 0, full_height = 0;
};
void write_exr(const std::string& path, const Image& image, const Metadata& metadata,
               const std::vector<ExtraChannel>& extra, const DataWindow& window = {});
// Every channel of an image file by name (R, G, B, the AOVs' "albedo.R", "N.X", "Z", ...),
// interleaved as stored; the size is the data window's, and `window` says where it sits (an EXR
// crop: write it with the same window to keep the crop in place; other formats: the whole).
struct ChannelImage {
  int width = 0, height = 0;
  DataWindow window;
  std::vector<std::string> names;
  std::vector<float> values;  // width * height * names.size()
  int find(const std::string& name) const;  // the channel's index, -1 if absent
  // Three channels as an Image; throws ImageIoError naming `path` if one is missing.
  Image gather(const std::string& path, const std::string& a, const std::string& b, const std::string& c) const;
};
ChannelImage read_channels(const std::string& path);
// Writes an 8-bit sRGB PNG (exposure 1, clamped), atomically as above.
void write_png(const std::string& path, const Image& image);
// Reads an image (EXR, HDR, PNG, JPEG, BMP, GIF, PNM) as linear RGB (integer files
// are decoded from sRGB unless a PNG is tagged linear: gAMA 1.0 and no sRGB chunk). Alpha and extra channels are dropped; grey is expanded to RGB.
// `colour_channels` (if given) receives 1 for a grey file, 3 for a colour one.
Image read_image(const std::string& path, int* colour_channels = nullptr);
// How an image file's stored values become linear: as the file says (read_image's rule:
// integer files are sRGB unless tagged linear, float files linear), or forced either way (a
// colour texture known to be sRGB, or one stored linearly in 8 bits without saying so).
enum class StoredEncoding { kAsFile, kSrgb, kLinear };
// read_image with that choice; *decoded_srgb (if given) says whether sRGB was decoded.
Image read_image(const std::string& path, StoredEncoding encoding, bool* decoded_srgb);
// Writes one channel of data, values in [0, 1] (clamped; NaN as 0), as a 16-bit grey PNG storing
// round(65535 v) with no transfer function (tagged linear): texture bindings read it back as
// v to 1/65535 (docs/stack_bindings.md, "Maps are data"). Atomically as above.
void write_data_png16(const std::string& path, int width, int height, const std::vector<float>& values);
// The most samples (width x height x channels) read_image decodes: 2^28 floats, 1 GiB, a
// 9459 x 9459 RGB image. A larger header is refused before anything is allocated.
constexpr std::size_t kMaxImageSamples = std::size_t(1) << 28;
// The sRGB transfer function (IEC 61966-2-1) and its inverse, on [0, 1]; encode clamps and
// maps NaN to 0.
double srgb_encode(double linear);
double srgb_decode(double encoded);

// Where an EXR's pixels sit in its display window (a crop, as write_exr's DataWindow), from the
// header alone; the whole image ({}) for other formats. Throws ImageIoError as read_metadata.
DataWindow read_data_window(const std::string& path);

// Reads the string attributes of an EXR header (e.g. a batch job's hash); none for other
// formats (the file must still be a readable image).
Metadata read_metadata(const std::string& path);

}  // namespace lamina
