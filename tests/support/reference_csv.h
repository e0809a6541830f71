// Reference tables written by the scripts/*_reference.py generators: a header line, then rows of
// a name and numbers, comma-separated. Read here once for every test that compares against one.
#pragma once

#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

namespace lamina::test {

struct ReferenceRow {
  std::string name;
  std::vector<double> v;
  std::string line;  // for messages
};

// The rows of LAMINA_SOURCE_DIR/relative_path; a missing file is a test failure (no rows).
inline std::vector<ReferenceRow> read_reference_csv(const std::string& source_dir, const std::string& relative_path) {
  std::vector<ReferenceRow> rows;
  std::ifstream in(source_dir + "/" + relative_path);
  if (!in) {
    ADD_FAILURE() << "cannot read " << relative_path;
    return rows;
  }
  std::string line;
  std::getline(in, line);  // the header
  while (std::getline(in, line)) {
    std::stringstream ss(line);
    ReferenceRow row;
    row.line = line;
    std::getline(ss, row.name, ',');
    for (std::string tok; std::getline(ss, tok, ',');) row.v.push_back(std::stod(tok));
    rows.push_back(row);
  }
  return rows;
}

}  // namespace lamina::test
