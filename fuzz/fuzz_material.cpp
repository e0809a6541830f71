// The material (stack) file reader (materials/stack/stack_file), then the stack's validation.
#include <string>

#include "fuzz/fuzz_input.h"
#include "materials/stack/stack_file.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  return lamina::fuzz::refuse_cleanly([&] {
    const lamina::StackTemplate t = lamina::parse_stack_template_json(text, "fuzz.json");
    (void)lamina::validate_stack(t.stack);
  });
}
