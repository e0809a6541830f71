// Reading a whole input file, with the reason when it cannot be read: every reader of text
// inputs (material files, measurement CSVs, material maps, manifests, glTF) says why in the same
// words, "FILE: cannot read the file: REASON" or the reader's own phrase before the reason.
#pragma once

#include <string>

namespace lamina {

// Why `path` cannot be read: "does not exist", "is a directory, not a file", "is not a regular
// file", "permission denied", or the system's reason (strerror). "" if it can be opened.
std::string file_unreadable_reason(const std::string& path);

// The whole file into *text; returns "" or the reason (as above, or "read error: ...").
std::string read_text_file(const std::string& path, std::string* text);

}  // namespace lamina
