// Image files (see image_io.h): OpenEXR for EXR, stb_image for reading the integer formats and
// Radiance HDR, libpng for writing PNG. Lamina used OpenImageIO before; on Debian it pulls in
// about 260 shared libraries (video codecs, OpenCV, GDAL), whose relocation took 0.3-0.4 s at
// the start of every lamina and test process. These three cover every format Lamina reads or
// writes (docs/contracts.md, "Images") with a few libraries.
#include "renderer/image/image_io.h"

#include <cerrno>
#include <csetjmp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <memory>
#include <mutex>
#include <set>
#include <string>

#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfInputFile.h>
#include <OpenEXR/ImfOutputFile.h>
#include <OpenEXR/ImfStandardAttributes.h>
#include <OpenEXR/ImfStringAttribute.h>
#include <png.h>
// stb_image compiled here, static to this file: the formats Lamina reads and no others (TGA has no
// signature and would accept almost any file; PSD and PIC are not images a user brings), and
// instrumented with the rest of Lamina when scripts/fuzz.sh builds it with sanitizers (a shared
// libstb would be a blind spot of the fuzzer).
#define STB_IMAGE_STATIC
#define STB_IMAGE_IMPLEMENTATION
#define STBI_ONLY_PNG
#define STBI_ONLY_JPEG
#define STBI_ONLY_HDR
#define STBI_ONLY_BMP
#define STBI_ONLY_GIF
#define STBI_ONLY_PNM
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wunused-function"  // the parts of stb_image Lamina does not call
#include <stb_image.h>
#pragma GCC diagnostic pop

#include "renderer/util/atomic_file.h"
#include "renderer/util/finite_output.h"

namespace lamina {
namespace {

// Writes through `write(tmp)` to a temporary file, then renames it over `path`. Any failure
// removes the temporary file and throws ImageIoError naming `path`; `path` itself is then
// untouched.
template <typename Write>
void write_atomically(const std::string& path, Write write) {
  const std::string tmp = temporary_path(path);
  try {
    write(tmp);
  } catch (const std::exception& e) {
    std::remove(tmp.c_str());
    throw ImageIoError("cannot write '" + path + "': " + e.what());
  }
  try {
    commit_temporary(tmp, path);
  } catch (const AtomicWriteError& e) {
    throw ImageIoError(e.what());
  }
}

void check_size(const std::string& path, const Image& image) {
  if (image.width <= 0 || image.height <= 0 ||
      image.rgb.size() != static_cast<std::size_t>(image.width) * image.height * 3)
    throw ImageIoError("cannot write '" + path + "': empty or inconsistent image");
}

struct WriteError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// One PNG through libpng: `bit_depth` 8 or 16, `channels` 1 (grey) or 3 (RGB), samples in
// row order (16-bit in host order); `linear` tags the file gAMA 1.0, else it is tagged sRGB.
// libpng reports errors through longjmp: the handler records the message.
void write_png_file(const std::string& tmp, int width, int height, int channels, int bit_depth, const void* samples,
                    bool linear) {
  struct Context {
    char message[256] = "libpng error";
    std::jmp_buf jump;
  } context;
  std::FILE* file = std::fopen(tmp.c_str(), "wb");
  if (!file) throw WriteError(std::string("cannot create file (") + std::strerror(errno) + ")");
  png_structp png = png_create_write_struct(
      PNG_LIBPNG_VER_STRING, &context,
      [](png_structp p, png_const_charp message) {
        auto* c = static_cast<Context*>(png_get_error_ptr(p));
        std::snprintf(c->message, sizeof c->message, "%s", message);
        std::longjmp(c->jump, 1);
      },
      [](png_structp, png_const_charp) {});
  png_infop info = png ? png_create_info_struct(png) : nullptr;
  if (!png || !info) {
    png_destroy_write_struct(&png, nullptr);
    std::fclose(file);
    throw WriteError("out of memory");
  }
  const std::size_t row_bytes = static_cast<std::size_t>(width) * channels * (bit_depth / 8);
  if (setjmp(context.jump)) {
    png_destroy_write_struct(&png, &info);
    std::fclose(file);
    throw WriteError(context.message);
  }
  png_init_io(png, file);
  png_set_IHDR(png, info, static_cast<png_uint_32>(width), static_cast<png_uint_32>(height), bit_depth,
               channels == 1 ? PNG_COLOR_TYPE_GRAY : PNG_COLOR_TYPE_RGB, PNG_INTERLACE_NONE,
               PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  if (linear) png_set_gAMA(png, info, 1.0);
  else png_set_sRGB_gAMA_and_cHRM(png, info, PNG_sRGB_INTENT_PERCEPTUAL);
  png_write_info(png, info);
  if (bit_depth == 16) png_set_swap(png);  // PNG stores 16-bit samples big-endian
  const auto* bytes = static_cast<const unsigned char*>(samples);
  for (int y = 0; y < height; ++y) png_write_row(png, bytes + static_cast<std::size_t>(y) * row_bytes);
  png_write_end(png, info);
  png_destroy_write_struct(&png, &info);
  if (std::fclose(file) != 0) throw WriteError(std::string("write failed (") + std::strerror(errno) + ")");
}

// OpenEXR 3.1 trusts the sizes in a header: a string attribute that claims 2 GB is allocated
// and filled before the file is found to be short (fuzz_image: a 1 kB file took 2 GB). So the
// headers are walked here first, and every attribute must fit in the file (OpenEXR file layout,
// "Header": attributes of name\0 type\0 int32 size, value; an empty name ends a header; a
// multi-part file, version flag bit 12, has headers until an empty one). Returns "" if the file
// (read from its start) is not an EXR or its headers are consistent, else the reason.
std::string exr_header_problem(std::FILE* f, long size) {
  auto read_u32 = [&](std::uint32_t* v) {
    unsigned char b[4];
    if (std::fread(b, 1, 4, f) != 4) return false;
    *v = b[0] | (b[1] << 8) | (b[2] << 16) | (static_cast<std::uint32_t>(b[3]) << 24);
    return true;
  };
  auto read_name = [&](std::string* out) {  // at most 255 bytes and a NUL
    out->clear();
    for (int c; (c = std::fgetc(f)) != 0;) {
      if (c == EOF || out->size() >= 255) return false;
      out->push_back(static_cast<char>(c));
    }
    return true;
  };
  std::string why;
  std::uint32_t magic = 0, version = 0;
  if (read_u32(&magic) && magic == 20000630u && read_u32(&version)) {
    const bool multipart = (version & 0x1000u) != 0;
    for (int header = 0; why.empty(); ++header) {
      std::string name, type;
      std::set<std::string> names;
      int attributes = 0;
      for (;; ++attributes) {
        if (!read_name(&name)) { why = "truncated or corrupt header"; break; }
        if (name.empty()) break;
        names.insert(name);
        std::uint32_t n = 0;
        if (!read_name(&type) || !read_u32(&n)) { why = "truncated or corrupt header"; break; }
        const long at = std::ftell(f);
        const std::int32_t claimed = static_cast<std::int32_t>(n);  // the size is a signed int
        if (claimed < 0 || claimed > size - at) {
          why = "corrupt header: attribute '" + name + "' claims " + std::to_string(claimed) + " bytes, the file has " +
                std::to_string(size - at) + " left";
          break;
        }
        std::fseek(f, static_cast<long>(claimed), SEEK_CUR);
      }
      // A single-part file has one header, which must hold the attributes every OpenEXR file
      // has ("Header": channels, compression, dataWindow, displayWindow, lineOrder,
      // pixelAspectRatio, screenWindowCenter, screenWindowWidth; OpenEXR assumed defaults for a
      // missing one and grew to 1.9 GB on a 615-byte file, fuzz_image). A multi-part file
      // ends with an empty header.
      if (!multipart) {
        for (const char* required : {"channels", "compression", "dataWindow", "displayWindow", "lineOrder",
                                     "pixelAspectRatio", "screenWindowCenter", "screenWindowWidth"})
          if (why.empty() && !names.count(required)) why = std::string("corrupt header: no '") + required + "' attribute";
        break;
      }
      if (attributes == 0 && header > 0) break;
    }
  }
  return why;
}

// A PNG's chunks, walked before any decoder sees the file. Decoders allocate an ancillary chunk's
// claimed length before reading it (fuzz_image: a 325-byte PNG whose chunk claimed 1.3 GB), so
// each chunk's length (PNG specification, section 5.3: a 4-byte big-endian length, at most
// 2^31 - 1, a 4-byte type, the data, a 4-byte CRC) must fit in what is left of the file. The
// walk also reads the colour tags the decoder ignores: an sRGB chunk, and gAMA (the file gamma
// times 100000; 100000 marks linear data, as Lamina's own 16-bit data maps are written).
struct PngScan {
  bool is_png = false;
  std::string problem;   // "" if the chunk lengths are consistent
  bool srgb_chunk = false;
  long gamma = -1;       // the gAMA value, -1 if absent
  // Integer PNG samples are sRGB-encoded unless the file says linear (gAMA 1.0 and no sRGB).
  bool linear() const { return !srgb_chunk && gamma >= 99000 && gamma <= 101000; }
};

PngScan scan_png(std::FILE* f, long size) {
  static const unsigned char kSignature[8] = {0x89, 'P', 'N', 'G', 0x0d, 0x0a, 0x1a, 0x0a};
  unsigned char sig[8];
  PngScan scan;
  if (std::fread(sig, 1, 8, f) != 8 || std::memcmp(sig, kSignature, 8) != 0) return scan;
  scan.is_png = true;
  unsigned char head[8];
  while (std::fread(head, 1, 8, f) == 8) {
    const std::uint32_t length = (static_cast<std::uint32_t>(head[0]) << 24) | (head[1] << 16) | (head[2] << 8) | head[3];
    const std::string type(reinterpret_cast<const char*>(head + 4), 4);
    const long left = size - std::ftell(f);
    if (length > 0x7fffffffu || static_cast<double>(length) + 4.0 > static_cast<double>(left)) {
      scan.problem = "corrupt PNG: chunk '" + type + "' claims " + std::to_string(length) + " bytes, the file has " +
                     std::to_string(std::max(0L, left - 4)) + " left";
      break;
    }
    if (type == "IEND") break;
    if (type == "sRGB") scan.srgb_chunk = true;
    if (type == "gAMA" && length == 4) {
      unsigned char g[4];
      if (std::fread(g, 1, 4, f) != 4) break;
      scan.gamma = static_cast<long>((static_cast<std::uint32_t>(g[0]) << 24) | (g[1] << 16) | (g[2] << 8) | g[3]);
      std::fseek(f, 4, SEEK_CUR);  // CRC
      continue;
    }
    std::fseek(f, static_cast<long>(length) + 4, SEEK_CUR);  // data and CRC
  }
  return scan;
}

// What the first bytes of a file say it is.
enum class Container { kExr, kPng, kOther };

// The container checks above for any file Lamina reads, one open: its kind, and the reason it
// is refused ("" if fine, or if the file cannot be opened: the reader then says why).
struct ContainerCheck {
  Container kind = Container::kOther;
  std::string problem;
  bool png_linear = false;
};

ContainerCheck check_container(const std::string& path) {
  ContainerCheck check;
  std::FILE* f = std::fopen(path.c_str(), "rb");
  if (!f) return check;
  std::fseek(f, 0, SEEK_END);
  const long size = std::ftell(f);
  std::fseek(f, 0, SEEK_SET);
  unsigned char magic[4] = {0, 0, 0, 0};
  const bool exr = std::fread(magic, 1, 4, f) == 4 && magic[0] == 0x76 && magic[1] == 0x2f && magic[2] == 0x31 &&
                   magic[3] == 0x01;
  std::fseek(f, 0, SEEK_SET);
  if (exr) {
    check.kind = Container::kExr;
    check.problem = exr_header_problem(f, size);
  } else {
    const PngScan png = scan_png(f, size);
    if (png.is_png) {
      check.kind = Container::kPng;
      check.problem = png.problem;
      check.png_linear = png.linear();
    }
  }
  std::fclose(f);
  return check;
}

// A file's samples as floats, as stored: integers divided by their maximum, no colour
// transform. `srgb_encoded`: integer samples with no linear tag (read_image decodes them).
struct RawImage {
  int width = 0, height = 0;
  std::vector<std::string> names;
  std::vector<float> values;  // width * height * names.size(), interleaved
  bool srgb_encoded = false;
  DataWindow window;  // EXR: where the pixels sit in the display window
};

void check_samples(const std::string& path, double width, double height, double channels) {
  if (!(width > 0 && height > 0 && channels > 0)) throw ImageIoError("cannot read '" + path + "': empty image");
  if (width * height * channels > static_cast<double>(kMaxImageSamples))
    throw ImageIoError("cannot read '" + path + "': " + std::to_string(static_cast<long long>(width)) + " x " +
                       std::to_string(static_cast<long long>(height)) + " x " +
                       std::to_string(static_cast<long long>(channels)) + " channels exceeds the limit of " +
                       std::to_string(kMaxImageSamples) + " samples (1 GiB of floats)");
}

// The data window of an EXR's first part, every channel (names in the file's order, which
// OpenEXR keeps sorted).
RawImage read_exr(const std::string& path) {
  RawImage raw;
  try {
    Imf::InputFile file(path.c_str());
    const Imf::Header& header = file.header();
    const Imath::Box2i window = header.dataWindow();
    const double width = static_cast<double>(window.max.x) - window.min.x + 1.0;
    const double height = static_cast<double>(window.max.y) - window.min.y + 1.0;
    std::vector<std::string> names;
    for (auto c = header.channels().begin(); c != header.channels().end(); ++c) {
      if (c.channel().xSampling != 1 || c.channel().ySampling != 1)
        throw ImageIoError("cannot read '" + path + "': channel " + c.name() + " is subsampled (not supported)");
      names.emplace_back(c.name());
    }
    check_samples(path, width, height, static_cast<double>(names.size()));
    raw.width = static_cast<int>(width);
    raw.height = static_cast<int>(height);
    raw.names = names;
    // A crop's data window inside a larger display window (write_exr's DataWindow).
    const Imath::Box2i display = header.displayWindow();
    raw.window.x = window.min.x;
    raw.window.y = window.min.y;
    if (display != window) {
      raw.window.full_width = display.max.x + 1;
      raw.window.full_height = display.max.y + 1;
    }
    const std::size_t nc = names.size();
    raw.values.assign(static_cast<std::size_t>(raw.width) * raw.height * nc, 0.0f);
    Imf::FrameBuffer frame;
    for (std::size_t c = 0; c < nc; ++c)
      frame.insert(names[c], Imf::Slice::Make(Imf::FLOAT, raw.values.data() + c, window, sizeof(float) * nc,
                                              sizeof(float) * nc * static_cast<std::size_t>(raw.width)));
    file.setFrameBuffer(frame);
    file.readPixels(window.min.y, window.max.y);
  } catch (const ImageIoError&) {
    throw;
  } catch (const std::exception& e) {
    throw ImageIoError("cannot read '" + path + "': " + e.what());
  }
  return raw;
}

// The integer formats (PNG, JPEG, BMP, GIF, PNM) and Radiance HDR through stb_image.
RawImage read_stb(const std::string& path, bool png_linear) {
  // stb_image keeps its failure reason in a global: one reader at a time.
  static std::mutex mutex;
  const std::lock_guard<std::mutex> lock(mutex);
  int width = 0, height = 0, channels = 0;
  if (!stbi_info(path.c_str(), &width, &height, &channels)) {
    std::FILE* f = std::fopen(path.c_str(), "rb");
    if (!f) throw ImageIoError("cannot read '" + path + "': " + std::strerror(errno));
    std::fclose(f);
    throw ImageIoError("cannot read '" + path + "': not an image Lamina reads (EXR, PNG, JPEG, HDR, BMP, GIF, PNM)" +
                       std::string(stbi_failure_reason() ? std::string(": ") + stbi_failure_reason() : ""));
  }
  check_samples(path, width, height, channels);
  RawImage raw;
  raw.width = width;
  raw.height = height;
  static const std::vector<std::string> kNames[5] = {{}, {"Y"}, {"Y", "A"}, {"R", "G", "B"}, {"R", "G", "B", "A"}};
  if (channels < 1 || channels > 4) throw ImageIoError("cannot read '" + path + "': unsupported channel count");
  raw.names = kNames[channels];
  const std::size_t n = static_cast<std::size_t>(width) * height * channels;
  raw.values.resize(n);
  int w = 0, h = 0, c = 0;
  auto failed = [&]() {
    return ImageIoError("cannot read '" + path + "': " +
                        (stbi_failure_reason() ? stbi_failure_reason() : "decoding failed") + " (truncated or corrupt file?)");
  };
  if (stbi_is_hdr(path.c_str())) {
    std::unique_ptr<float, void (*)(void*)> data(stbi_loadf(path.c_str(), &w, &h, &c, channels), stbi_image_free);
    if (!data || w != width || h != height) throw failed();
    std::copy(data.get(), data.get() + n, raw.values.begin());
  } else if (stbi_is_16_bit(path.c_str())) {
    std::unique_ptr<std::uint16_t, void (*)(void*)> data(stbi_load_16(path.c_str(), &w, &h, &c, channels), stbi_image_free);
    if (!data || w != width || h != height) throw failed();
    for (std::size_t i = 0; i < n; ++i) raw.values[i] = data.get()[i] / 65535.0f;
    raw.srgb_encoded = !png_linear;
  } else {
    std::unique_ptr<unsigned char, void (*)(void*)> data(stbi_load(path.c_str(), &w, &h, &c, channels), stbi_image_free);
    if (!data || w != width || h != height) throw failed();
    for (std::size_t i = 0; i < n; ++i) raw.values[i] = data.get()[i] / 255.0f;
    raw.srgb_encoded = !png_linear;
  }
  return raw;
}

// Every channel of the file at `path`. Throws ImageIoError("cannot read 'path': why").
RawImage read_raw(const std::string& path) {
  const ContainerCheck check = check_container(path);
  if (!check.problem.empty()) throw ImageIoError("cannot read '" + path + "': " + check.problem);
  if (check.kind == Container::kExr) return read_exr(path);
  return read_stb(path, check.png_linear);
}

int channel_index(const RawImage& raw, const std::string& name) {
  for (std::size_t c = 0; c < raw.names.size(); ++c)
    if (raw.names[c] == name) return static_cast<int>(c);
  return -1;
}

}  // namespace

// The IEC 61966-2-1 (sRGB) transfer function: linear below 0.0031308, a 2.4 power above.
double srgb_encode(double linear) {
  if (!(linear > 0.0)) return 0.0;  // also maps NaN to black
  if (linear >= 1.0) return 1.0;
  return linear <= 0.0031308 ? 12.92 * linear : 1.055 * std::pow(linear, 1.0 / 2.4) - 0.055;
}
double srgb_decode(double encoded) {
  return encoded <= 0.04045 ? encoded / 12.92 : std::pow((encoded + 0.055) / 1.055, 2.4);
}

void write_exr(const std::string& path, const Image& image, const Metadata& metadata) {
  write_exr(path, image, metadata, {});
}

namespace {

// The header attributes that hold the user's own words (names, paths, the command line, --meta),
// where "nan" may be a camera's name: every other lamina: attribute is Lamina's numbers, lists
// of them or sentences around them.
bool is_text_attribute(const std::string& key) {
  static const char* const kText[] = {"lamina:version",           "lamina:command",       "lamina:scene",
                                      "lamina:camera",            "lamina:env",           "lamina:stack",
                                      "lamina:job_id",            "lamina:job_hash",      "lamina:denoised",
                                      "lamina:compare:reference", "lamina:compare:test"};
  if (key.rfind("lamina:", 0) != 0) return true;  // --meta KEY=VALUE: the user's
  for (const char* k : kText)
    if (key == k) return true;
  return false;
}

// Every number the header holds is finite, or nothing is written (docs/contracts.md, "Outputs").
void check_header_numbers(const std::string& path, const Metadata& metadata) {
  for (const auto& [key, value] : metadata)
    if (!is_text_attribute(key))
      if (const std::string word = first_non_finite_word(value); !word.empty())
        throw ImageIoError(non_finite_message(path, "header attribute " + key, "'" + value + "'"));
}

}  // namespace

void write_exr(const std::string& path, const Image& image, const Metadata& metadata,
               const std::vector<ExtraChannel>& extra, const DataWindow& window) {
  check_size(path, image);
  check_header_numbers(path, metadata);
  const std::size_t pixels = static_cast<std::size_t>(image.width) * image.height;
  for (const ExtraChannel& c : extra)
    if (c.values.size() != pixels) throw ImageIoError(path + ": channel " + c.name + " has the wrong size");
  const Imath::Box2i data(Imath::V2i(window.x, window.y),
                          Imath::V2i(window.x + image.width - 1, window.y + image.height - 1));
  const Imath::Box2i display = window.full_width > 0
                                   ? Imath::Box2i(Imath::V2i(0, 0), Imath::V2i(window.full_width - 1, window.full_height - 1))
                                   : data;
  write_atomically(path, [&](const std::string& tmp) {
    Imf::Header header(display, data, 1.0f, Imath::V2f(0.0f, 0.0f), 1.0f, Imf::INCREASING_Y, Imf::ZIP_COMPRESSION);
    for (const auto& [key, value] : metadata) header.insert(key, Imf::StringAttribute(value));
    // The pixels are linear Rec. 709 (sRGB primaries) with a D65 white (docs/contracts.md,
    // "Colour"): said in the standard attribute, which viewers and compositors read.
    Imf::addChromaticities(header, Imf::Chromaticities(Imath::V2f(0.64f, 0.33f), Imath::V2f(0.30f, 0.60f),
                                                       Imath::V2f(0.15f, 0.06f), Imath::V2f(0.3127f, 0.3290f)));
    Imf::FrameBuffer frame;
    const std::size_t row = sizeof(float) * 3 * static_cast<std::size_t>(image.width);
    for (int c = 0; c < 3; ++c) {
      const char* name = c == 0 ? "R" : c == 1 ? "G" : "B";
      header.channels().insert(name, Imf::Channel(Imf::FLOAT));
      frame.insert(name, Imf::Slice::Make(Imf::FLOAT, image.rgb.data() + c, data, sizeof(float) * 3, row));
    }
    for (const ExtraChannel& c : extra) {
      header.channels().insert(c.name, Imf::Channel(Imf::FLOAT));
      frame.insert(c.name, Imf::Slice::Make(Imf::FLOAT, c.values.data(), data, sizeof(float),
                                            sizeof(float) * static_cast<std::size_t>(image.width)));
    }
    Imf::OutputFile file(tmp.c_str(), header);
    file.setFrameBuffer(frame);
    file.writePixels(image.height);
  });
}

void write_png(const std::string& path, const Image& image) {
  check_size(path, image);
  std::vector<unsigned char> bytes(image.rgb.size());
  for (std::size_t i = 0; i < bytes.size(); ++i)
    bytes[i] = static_cast<unsigned char>(std::lround(255.0 * srgb_encode(image.rgb[i])));
  write_atomically(path, [&](const std::string& tmp) {
    write_png_file(tmp, image.width, image.height, 3, 8, bytes.data(), false);
  });
}

void write_data_png16(const std::string& path, int width, int height, const std::vector<float>& values) {
  if (width <= 0 || height <= 0 || values.size() != static_cast<std::size_t>(width) * height)
    throw ImageIoError("cannot write '" + path + "': empty or inconsistent image");
  std::vector<std::uint16_t> stored(values.size());
  for (std::size_t i = 0; i < stored.size(); ++i) {
    const float v = values[i];
    stored[i] = static_cast<std::uint16_t>(v > 0.0f ? std::lround(65535.0 * std::min(v, 1.0f)) : 0);  // NaN: 0
  }
  write_atomically(path, [&](const std::string& tmp) { write_png_file(tmp, width, height, 1, 16, stored.data(), true); });
}

// The one reader behind both read_image overloads.
static Image read_image(const std::string& path, StoredEncoding encoding, bool* decoded_srgb, int* colour_channels);

Image read_image(const std::string& path, int* colour_channels) {
  return read_image(path, StoredEncoding::kAsFile, nullptr, colour_channels);
}

Image read_image(const std::string& path, StoredEncoding encoding, bool* decoded_srgb) {
  return read_image(path, encoding, decoded_srgb, nullptr);
}

static Image read_image(const std::string& path, StoredEncoding encoding, bool* decoded_srgb, int* colour_channels) {
  const RawImage raw = read_raw(path);
  const int nc = static_cast<int>(raw.names.size());
  // Which file channels become R, G, B: named R/G/B if present, grey (one channel, or grey +
  // alpha) replicated, otherwise the first three channels.
  int src[3] = {0, 1, 2};
  const int r = channel_index(raw, "R"), g = channel_index(raw, "G"), b = channel_index(raw, "B");
  if (r >= 0 && g >= 0 && b >= 0) {
    src[0] = r, src[1] = g, src[2] = b;
  } else if (nc < 3) {
    const int y = channel_index(raw, "Y");
    src[0] = src[1] = src[2] = (y >= 0 ? y : 0);
  }
  if (colour_channels) *colour_channels = (src[0] == src[1] && src[1] == src[2]) ? 1 : 3;
  const bool srgb = encoding == StoredEncoding::kSrgb || (encoding == StoredEncoding::kAsFile && raw.srgb_encoded);
  if (decoded_srgb) *decoded_srgb = srgb;
  Image image(raw.width, raw.height);
  const std::size_t n = static_cast<std::size_t>(raw.width) * raw.height;
  for (std::size_t i = 0; i < n; ++i)
    for (int c = 0; c < 3; ++c) {
      const float v = raw.values[i * nc + src[c]];
      image.rgb[i * 3 + c] = srgb ? static_cast<float>(srgb_decode(v)) : v;
    }
  return image;
}

ChannelImage read_channels(const std::string& path) {
  RawImage raw = read_raw(path);
  ChannelImage out;
  out.width = raw.width;
  out.height = raw.height;
  out.names = std::move(raw.names);
  out.values = std::move(raw.values);
  out.window = raw.window;
  return out;
}

int ChannelImage::find(const std::string& name) const {
  for (std::size_t c = 0; c < names.size(); ++c)
    if (names[c] == name) return static_cast<int>(c);
  return -1;
}

Image ChannelImage::gather(const std::string& path, const std::string& a, const std::string& b, const std::string& c) const {
  const int src[3] = {find(a), find(b), find(c)};
  for (int k = 0; k < 3; ++k)
    if (src[k] < 0) throw ImageIoError(path + ": no channel " + (k == 0 ? a : k == 1 ? b : c));
  Image image(width, height);
  const std::size_t n = static_cast<std::size_t>(width) * height, nc = names.size();
  for (std::size_t i = 0; i < n; ++i)
    for (int k = 0; k < 3; ++k) image.rgb[i * 3 + k] = values[i * nc + static_cast<std::size_t>(src[k])];
  return image;
}

Metadata read_metadata(const std::string& path) {
  const ContainerCheck check = check_container(path);
  if (!check.problem.empty()) throw ImageIoError("cannot read '" + path + "': " + check.problem);
  Metadata metadata;
  if (check.kind != Container::kExr) {
    // Other formats carry no header attributes Lamina writes; the file must still be an image.
    read_raw(path);
    return metadata;
  }
  try {
    Imf::InputFile file(path.c_str());
    for (auto a = file.header().begin(); a != file.header().end(); ++a)
      if (const auto* s = dynamic_cast<const Imf::StringAttribute*>(&a.attribute()))
        metadata.emplace_back(a.name(), s->value());
  } catch (const std::exception& e) {
    throw ImageIoError("cannot read '" + path + "': " + e.what());
  }
  return metadata;
}

DataWindow read_data_window(const std::string& path) {
  const ContainerCheck check = check_container(path);
  if (!check.problem.empty()) throw ImageIoError("cannot read '" + path + "': " + check.problem);
  if (check.kind != Container::kExr) return {};
  try {
    Imf::InputFile file(path.c_str());
    const Imath::Box2i data = file.header().dataWindow(), display = file.header().displayWindow();
    DataWindow w{data.min.x, data.min.y, 0, 0};
    if (display != data) {
      w.full_width = display.max.x + 1;
      w.full_height = display.max.y + 1;
    }
    return w;
  } catch (const std::exception& e) {
    throw ImageIoError("cannot read '" + path + "': " + e.what());
  }
}

}  // namespace lamina
