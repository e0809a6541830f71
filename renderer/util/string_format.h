// printf-style formatting into a std::string, for lines that library code hands to a caller's
// log (render_job, batch) instead of printing them itself.
#pragma once

#include <string>

namespace lamina {

std::string string_printf(const char* format, ...) __attribute__((format(printf, 1, 2)));

}  // namespace lamina
