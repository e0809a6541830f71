// Image files through OpenImageIO (see image_io.h).
#include "renderer/image/image_io.h"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <mutex>
#include <set>
#include <string>

#include <OpenImageIO/imageio.h>

#include "renderer/util/atomic_file.h"

namespace lamina {
namespace {

namespace OIIO = OIIO_NAMESPACE;

// Writes `pixels` (width*height*channels values of `type`) with the OIIO plugin `format` to a
// temporary file, then renames it over `path`. Any failure removes the temporary file and
// throws ImageIoError naming `path`; `path` itself is then untouched.
void write_atomically(const std::string& path, const std::string& format, const OIIO::ImageSpec& spec,
                      const void* pixels) {
  const std::string tmp = temporary_path(path);
  auto fail = [&](const std::string& why) {
    std::remove(tmp.c_str());
    throw ImageIoError("cannot write '" + path + "': " + why);
  };
  auto out = OIIO::ImageOutput::create(format);
  if (!out) fail("no " + format + " writer (" + OIIO::geterror() + ")");
  if (!out->open(tmp, spec)) {
    std::string why = out->geterror();
    fail(why.empty() ? "cannot create file" : why);
  }
  if (!out->write_image(spec.format, pixels)) {
    std::string why = out->geterror();
    out->close();
    fail(why);
  }
  if (!out->close()) fail(out->geterror());
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

// OpenImageIO reports the file's own colour space; integer files (PNG, JPEG) are sRGB-encoded
// unless they say they are linear, float files (EXR, HDR) are linear.
bool stored_as_srgb(const OIIO::ImageSpec& spec) {
  const OIIO::TypeDesc::BASETYPE base = static_cast<OIIO::TypeDesc::BASETYPE>(spec.format.basetype);
  const bool integer = base == OIIO::TypeDesc::UINT8 || base == OIIO::TypeDesc::UINT16 ||
                       base == OIIO::TypeDesc::INT8 || base == OIIO::TypeDesc::INT16;
  if (!integer) return false;
  std::string space = spec.get_string_attribute("oiio:ColorSpace");
  std::transform(space.begin(), space.end(), space.begin(), ::tolower);
  return space != "linear";
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

void write_exr(const std::string& path, const Image& image, const Metadata& metadata,
               const std::vector<ExtraChannel>& extra, const DataWindow& window) {
  check_size(path, image);
  const std::size_t pixels = static_cast<std::size_t>(image.width) * image.height;
  for (const ExtraChannel& c : extra)
    if (c.values.size() != pixels) throw ImageIoError(path + ": channel " + c.name + " has the wrong size");
  const int channels = 3 + static_cast<int>(extra.size());
  OIIO::ImageSpec spec(image.width, image.height, channels, OIIO::TypeDesc::FLOAT);
  spec.attribute("compression", "zip");
  if (window.full_width > 0) {
    spec.x = window.x;
    spec.y = window.y;
    spec.full_x = 0;
    spec.full_y = 0;
    spec.full_width = window.full_width;
    spec.full_height = window.full_height;
  }
  for (const auto& [key, value] : metadata) spec.attribute(key, value);
  if (extra.empty()) {
    write_atomically(path, "openexr", spec, image.rgb.data());
    return;
  }
  spec.channelnames = {"R", "G", "B"};
  for (const ExtraChannel& c : extra) spec.channelnames.push_back(c.name);
  std::vector<float> interleaved(pixels * static_cast<std::size_t>(channels));
  for (std::size_t i = 0; i < pixels; ++i) {
    float* p = &interleaved[i * static_cast<std::size_t>(channels)];
    for (int c = 0; c < 3; ++c) p[c] = image.rgb[i * 3 + static_cast<std::size_t>(c)];
    for (std::size_t k = 0; k < extra.size(); ++k) p[3 + k] = extra[k].values[i];
  }
  write_atomically(path, "openexr", spec, interleaved.data());
}

void write_png(const std::string& path, const Image& image) {
  check_size(path, image);
  std::vector<unsigned char> bytes(image.rgb.size());
  for (std::size_t i = 0; i < bytes.size(); ++i)
    bytes[i] = static_cast<unsigned char>(std::lround(255.0 * srgb_encode(image.rgb[i])));
  OIIO::ImageSpec spec(image.width, image.height, 3, OIIO::TypeDesc::UINT8);
  spec.attribute("oiio:ColorSpace", "sRGB");
  write_atomically(path, "png", spec, bytes.data());
}

void write_data_png16(const std::string& path, int width, int height, const std::vector<float>& values) {
  if (width <= 0 || height <= 0 || values.size() != static_cast<std::size_t>(width) * height)
    throw ImageIoError("cannot write '" + path + "': empty or inconsistent image");
  std::vector<std::uint16_t> stored(values.size());
  for (std::size_t i = 0; i < stored.size(); ++i) {
    const float v = values[i];
    stored[i] = static_cast<std::uint16_t>(v > 0.0f ? std::lround(65535.0 * std::min(v, 1.0f)) : 0);  // NaN: 0
  }
  OIIO::ImageSpec spec(width, height, 1, OIIO::TypeDesc::UINT16);
  spec.attribute("oiio:ColorSpace", "Linear");
  write_atomically(path, "png", spec, stored.data());
}

namespace {

// While alive, the process's stderr goes to /dev/null. OpenImageIO's PNG reader lets libpng print
// its own messages ("libpng error: ...") and prints errors it thinks nobody retrieved when a reader
// is destroyed; Lamina reports the same error itself, as one line naming the file
// (docs/contracts.md). Only for the short, single-threaded time of opening and reading a file
// (before rendering, or in `lamina compare`); a mutex keeps two readers from interleaving.
class QuietStderr {
 public:
  QuietStderr() : lock_(mutex()) {
    // LAMINA_IMAGE_IO_STDERR=1 keeps stderr (diagnosis; scripts/fuzz.sh sets it so that a
    // sanitizer's report from inside a reader is not lost).
    if (const char* keep = std::getenv("LAMINA_IMAGE_IO_STDERR"); keep && std::string(keep) == "1") return;
    std::fflush(stderr);
    saved_ = ::dup(2);
    const int null = ::open("/dev/null", O_WRONLY);
    if (saved_ >= 0 && null >= 0) ::dup2(null, 2);
    if (null >= 0) ::close(null);
  }
  ~QuietStderr() {
    std::fflush(stderr);
    if (saved_ >= 0) {
      ::dup2(saved_, 2);
      ::close(saved_);
    }
  }
  QuietStderr(const QuietStderr&) = delete;
  QuietStderr& operator=(const QuietStderr&) = delete;

 private:
  static std::mutex& mutex() {
    static std::mutex m;
    return m;
  }
  std::lock_guard<std::mutex> lock_;
  int saved_ = -1;
};


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

// libpng allocates an ancillary chunk's claimed length before reading it (fuzz_image: a 325-byte
// PNG whose chunk claimed 1.3 GB). So the chunks are walked here first: each chunk's length
// (PNG specification, section 5.3: a 4-byte big-endian length, at most 2^31 - 1, a 4-byte type,
// the data, a 4-byte CRC) must fit in what is left of the file. Returns "" if the file is not a
// PNG or its chunk lengths are consistent, else the reason.
std::string png_chunk_problem(std::FILE* f, long size) {
  static const unsigned char kSignature[8] = {0x89, 'P', 'N', 'G', 0x0d, 0x0a, 0x1a, 0x0a};
  unsigned char sig[8];
  std::string why;
  if (std::fread(sig, 1, 8, f) == 8 && std::memcmp(sig, kSignature, 8) == 0) {
    unsigned char head[8];
    while (why.empty() && std::fread(head, 1, 8, f) == 8) {
      const std::uint32_t length = (static_cast<std::uint32_t>(head[0]) << 24) | (head[1] << 16) | (head[2] << 8) | head[3];
      const std::string type(reinterpret_cast<const char*>(head + 4), 4);
      const long left = size - std::ftell(f);
      if (length > 0x7fffffffu || static_cast<double>(length) + 4.0 > static_cast<double>(left)) {
        why = "corrupt PNG: chunk '" + type + "' claims " + std::to_string(length) + " bytes, the file has " +
              std::to_string(std::max(0L, left - 4)) + " left";
        break;
      }
      if (type == "IEND") break;
      std::fseek(f, static_cast<long>(length) + 4, SEEK_CUR);  // data and CRC
    }
  }
  return why;
}

// The container checks above, for any file read_image or read_metadata opens: "" if it is fine
// (or neither EXR nor PNG: OpenImageIO then judges it), else the reason. One open, one size.
std::string container_problem(const std::string& path) {
  std::FILE* f = std::fopen(path.c_str(), "rb");
  if (!f) return "";  // OpenImageIO reports it, with its own reason
  std::fseek(f, 0, SEEK_END);
  const long size = std::ftell(f);
  std::fseek(f, 0, SEEK_SET);
  std::string why = exr_header_problem(f, size);
  if (why.empty()) {
    std::fseek(f, 0, SEEK_SET);
    why = png_chunk_problem(f, size);
  }
  std::fclose(f);
  return why;
}

}  // namespace

namespace {

// Every channel of the file at `path`, as floats interleaved in the file's order; *spec_out its
// header. Throws ImageIoError("cannot read 'path': why").
std::vector<float> read_all_channels(const std::string& path, OIIO::ImageSpec* spec_out) {
  auto fail = [&](const std::string& why) -> void {
    throw ImageIoError("cannot read '" + path + "': " + why);
  };
  if (const std::string why = container_problem(path); !why.empty()) fail(why);
  const QuietStderr quiet;
  auto in = OIIO::ImageInput::open(path);
  if (!in) {
    std::string why = OIIO::geterror();
    fail(why.empty() ? "cannot open file" : why);
  }
  const OIIO::ImageSpec& spec = in->spec();
  const int nc = spec.nchannels;
  if (spec.width <= 0 || spec.height <= 0 || nc <= 0) fail("empty image");
  if (spec.depth > 1) fail("volume images are not supported");
  // The header's size is the file's claim: refused before allocating above the limit.
  const double samples = static_cast<double>(spec.width) * spec.height * nc;
  if (samples > static_cast<double>(kMaxImageSamples))
    fail(std::to_string(spec.width) + " x " + std::to_string(spec.height) + " x " + std::to_string(nc) +
         " channels exceeds the limit of " + std::to_string(kMaxImageSamples) + " samples (1 GiB of floats)");
  std::vector<float> all(static_cast<std::size_t>(samples));
  if (!in->read_image(0, 0, 0, nc, OIIO::TypeDesc::FLOAT, all.data())) {
    std::string why = in->geterror();
    fail(why.empty() ? "read failed (truncated or corrupt file?)" : why);
  }
  *spec_out = spec;
  in->close();
  return all;
}

int channel_index(const OIIO::ImageSpec& spec, const std::string& name) {
  for (int c = 0; c < spec.nchannels; ++c)
    if (spec.channelnames.size() > static_cast<std::size_t>(c) && spec.channelnames[c] == name) return c;
  return -1;
}

}  // namespace

// The one reader behind both read_image overloads.
static Image read_image(const std::string& path, StoredEncoding encoding, bool* decoded_srgb, int* colour_channels);

Image read_image(const std::string& path, int* colour_channels) {
  return read_image(path, StoredEncoding::kAsFile, nullptr, colour_channels);
}

Image read_image(const std::string& path, StoredEncoding encoding, bool* decoded_srgb) {
  return read_image(path, encoding, decoded_srgb, nullptr);
}

static Image read_image(const std::string& path, StoredEncoding encoding, bool* decoded_srgb, int* colour_channels) {
  OIIO::ImageSpec spec;
  const std::vector<float> all = read_all_channels(path, &spec);
  const int nc = spec.nchannels;
  // Which file channels become R, G, B: named R/G/B if present, grey (one channel, or grey +
  // alpha) replicated, otherwise the first three channels.
  int src[3] = {0, 1, 2};
  const int r = channel_index(spec, "R"), g = channel_index(spec, "G"), b = channel_index(spec, "B");
  if (r >= 0 && g >= 0 && b >= 0) {
    src[0] = r, src[1] = g, src[2] = b;
  } else if (nc < 3) {
    const int y = channel_index(spec, "Y");
    src[0] = src[1] = src[2] = (y >= 0 ? y : 0);
  }
  if (colour_channels) *colour_channels = (src[0] == src[1] && src[1] == src[2]) ? 1 : 3;
  const bool srgb = encoding == StoredEncoding::kSrgb || (encoding == StoredEncoding::kAsFile && stored_as_srgb(spec));
  if (decoded_srgb) *decoded_srgb = srgb;
  Image image(spec.width, spec.height);
  const std::size_t n = static_cast<std::size_t>(spec.width) * spec.height;
  for (std::size_t i = 0; i < n; ++i)
    for (int c = 0; c < 3; ++c) {
      const float v = all[i * nc + src[c]];
      image.rgb[i * 3 + c] = srgb ? static_cast<float>(srgb_decode(v)) : v;
    }
  return image;
}

ChannelImage read_channels(const std::string& path) {
  OIIO::ImageSpec spec;
  ChannelImage out;
  out.values = read_all_channels(path, &spec);
  out.width = spec.width;
  out.height = spec.height;
  for (int c = 0; c < spec.nchannels; ++c)
    out.names.push_back(spec.channelnames.size() > static_cast<std::size_t>(c) ? spec.channelnames[c] : "");
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
  if (const std::string why = container_problem(path); !why.empty())
    throw ImageIoError("cannot read '" + path + "': " + why);
  auto in = OIIO::ImageInput::open(path);
  if (!in) {
    std::string why = OIIO::geterror();
    throw ImageIoError("cannot read '" + path + "': " + (why.empty() ? "cannot open file" : why));
  }
  Metadata metadata;
  for (const OIIO::ParamValue& p : in->spec().extra_attribs)
    if (p.type() == OIIO::TypeDesc::STRING) metadata.emplace_back(p.name().string(), p.get_string());
  in->close();
  return metadata;
}

}  // namespace lamina
