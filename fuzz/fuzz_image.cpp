// The image reader of `lamina compare` (renderer/image/image_io: OpenEXR, stb_image): EXR,
// PNG or HDR by content.
#include "fuzz/fuzz_input.h"
#include "renderer/image/image_io.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string path = lamina::fuzz::input_file(data, size, ".exr");
  return lamina::fuzz::refuse_cleanly([&] {
    int channels = 0;
    const lamina::Image image = lamina::read_image(path, &channels);
    (void)image;
  });
}
