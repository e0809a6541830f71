#include "tests/support/image_files.h"

#include <stdexcept>

#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfInputFile.h>
#include <OpenEXR/ImfOutputFile.h>
#include <stb_image.h>
#include <stb_image_write.h>

namespace lamina::test {

void write_png8(const std::string& path, int width, int height, int channels, const std::vector<unsigned char>& bytes) {
  if (!stbi_write_png(path.c_str(), width, height, channels, bytes.data(), width * channels))
    throw std::runtime_error("test: cannot write " + path);
}

void write_hdr(const std::string& path, int width, int height, const std::vector<float>& rgb) {
  if (!stbi_write_hdr(path.c_str(), width, height, 3, rgb.data())) throw std::runtime_error("test: cannot write " + path);
}

void write_exr_channels(const std::string& path, int width, int height, const std::vector<std::string>& names,
                        const std::vector<float>& values) {
  Imf::Header header(width, height);
  Imf::FrameBuffer frame;
  const std::size_t nc = names.size();
  for (std::size_t c = 0; c < nc; ++c) {
    header.channels().insert(names[c], Imf::Channel(Imf::FLOAT));
    frame.insert(names[c], Imf::Slice(Imf::FLOAT, const_cast<char*>(reinterpret_cast<const char*>(values.data() + c)),
                                      sizeof(float) * nc, sizeof(float) * nc * static_cast<std::size_t>(width)));
  }
  Imf::OutputFile file(path.c_str(), header);
  file.setFrameBuffer(frame);
  file.writePixels(height);
}

ExrWindows read_exr_windows(const std::string& path) {
  Imf::InputFile file(path.c_str());
  const Imath::Box2i data = file.header().dataWindow(), display = file.header().displayWindow();
  return {data.min.x, data.min.y, display.max.x - display.min.x + 1, display.max.y - display.min.y + 1};
}

std::vector<unsigned char> read_png8(const std::string& path, int* width, int* height, int* channels) {
  if (stbi_is_16_bit(path.c_str())) return {};
  unsigned char* data = stbi_load(path.c_str(), width, height, channels, 0);
  if (!data) return {};
  std::vector<unsigned char> out(data, data + static_cast<std::size_t>(*width) * *height * *channels);
  stbi_image_free(data);
  return out;
}

}  // namespace lamina::test
