// Every case of tests/corpus/*.cases.json (format: tests/corpus/README.md): hostile input is
// refused with one line naming the file or the argument, exit status 1 or 2, no signal, no hang,
// no output left behind.
#include <sys/wait.h>
#include <unistd.h>

#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "tests/renderer/cli/cli_runner.h"

namespace lamina::test {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

struct HostileCase {
  std::string file, name;
  json spec;
};

std::vector<HostileCase> load_cases() {
  std::vector<HostileCase> cases;
  std::vector<fs::path> files;
  for (const auto& e : fs::directory_iterator(LAMINA_CORPUS_DIR)) {
    const std::string n = e.path().filename().string();
    if (n.size() > 11 && n.compare(n.size() - 11, 11, ".cases.json") == 0) files.push_back(e.path());
  }
  std::sort(files.begin(), files.end());
  for (const fs::path& f : files) {
    std::ifstream in(f);
    const json j = json::parse(in);  // a broken cases file fails every test binary: loudly
    const std::string stem = f.filename().string().substr(0, f.filename().string().size() - 11);
    for (const json& c : j) cases.push_back({stem, c.at("name").get<std::string>(), c});
  }
  return cases;
}

std::string shell_quote(const std::string& s) {
  std::string q = "'";
  for (char c : s) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return q + "'";
}

std::string replace_all(std::string s, const std::string& from, const std::string& to) {
  for (std::size_t at = s.find(from); at != std::string::npos; at = s.find(from, at + to.size())) s.replace(at, from.size(), to);
  return s;
}

// Inputs too large to keep in the corpus, written by the test (tests/corpus/README.md).
std::string nested_arrays(int depth) { return std::string(depth, '[') + std::string(depth, ']'); }

fs::path generate(const json& spec, const fs::path& dir) {
  const std::string kind = spec.at("generate").get<std::string>();
  const int depth = spec.value("depth", 100000);
  fs::path path;
  std::string text;
  if (kind == "deep_extras_gltf") {
    path = dir / "input.gltf";
    text = R"({"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": []}], "materials": [{"name": "m", "extras": )" +
           nested_arrays(depth) + "}]}";
  } else if (kind == "deep_material") {
    path = dir / "input.json";
    text = R"({"lamina_material": 1, "layers": [{"thickness": 1, "ior": 1.4, "sigma_a": 1, "sigma_s": 1, "g": 0, "name": )" +
           nested_arrays(depth) + "}]}";
  } else if (kind == "deep_material_map") {
    path = dir / "input.json";
    text = R"({"m": )" + nested_arrays(depth) + "}";
  } else if (kind == "deep_manifest") {
    path = dir / "input.json";
    text = R"({"lamina_batch": 1, "description": )" + nested_arrays(depth) + "}";
  } else if (kind == "deep_glb") {
    // The same material extras in the JSON chunk of a .glb (glTF 2.0 spec, section 4.4: a 12-byte
    // header, then chunks of (length, type, data), the JSON chunk first, padded with spaces).
    path = dir / "input.glb";
    std::string chunk = R"({"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": []}], "materials": [{"name": "m", "extras": )" +
                        nested_arrays(depth) + "}]}";
    while (chunk.size() % 4) chunk += ' ';
    auto u32 = [&text](std::uint32_t v) {
      for (int i = 0; i < 4; ++i) text += static_cast<char>((v >> (8 * i)) & 0xFF);
    };
    u32(0x46546C67);  // "glTF"
    u32(2);
    u32(static_cast<std::uint32_t>(12 + 8 + chunk.size()));
    u32(static_cast<std::uint32_t>(chunk.size()));
    u32(0x4E4F534A);  // "JSON"
    text += chunk;
  } else if (kind == "node_line_gltf" || kind == "node_chain_gltf") {
    // node_line_gltf: a strict tree that is one line of `depth` nodes, each the only child of the
    // last: deeper than any real scene, and deeper than a recursive traversal may go.
    // node_chain_gltf: each node names the next one twice as a child: a DAG, not a tree; visited
    // naively it takes 2^depth visits.
    const bool twice = kind == "node_chain_gltf";
    path = dir / "input.gltf";
    std::ostringstream s;
    s << R"({"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [)";
    for (int i = 0; i < depth; ++i) {
      if (i) s << ", ";
      if (i + 1 < depth) s << "{\"children\": [" << i + 1 << (twice ? ", " + std::to_string(i + 1) : "") << "]}";
      else s << "{}";
    }
    s << "]}";
    text = s.str();
  } else if (kind == "copy") {
    // A copy of a corpus file (`from`, relative to the corpus) that the case may try to
    // overwrite: the corpus itself is never at risk, and the test checks the copy is unchanged.
    const fs::path from = fs::path(LAMINA_CORPUS_DIR) / spec.at("from").get<std::string>();
    path = dir / ("input" + from.extension().string());
    text = slurp(from);
    if (text.empty()) ADD_FAILURE() << "copy: cannot read " << from;
  } else {
    ADD_FAILURE() << "unknown generator '" << kind << "'";
    return {};
  }
  std::ofstream(path, std::ios::binary) << text;
  return path;
}

// gtest prints a failing parameter with this (not as raw bytes).
void PrintTo(const HostileCase& c, std::ostream* os) { *os << c.file << ".cases.json: " << c.name; }

class HostileInput : public ::testing::TestWithParam<HostileCase> {};

TEST_P(HostileInput, IsRefusedCleanly) {
  const HostileCase& c = GetParam();
  // The process id in the name: two suites running at once (a sanitized and a plain build)
  // must not remove each other's files.
  const fs::path dir = fs::path(::testing::TempDir()) / ("lamina_hostile_" + std::to_string(::getpid()) + "_" + c.file + "_" + c.name);
  fs::remove_all(dir);
  const fs::path out = dir / "out", work = dir / "work";
  fs::create_directories(out);
  fs::create_directories(work);
  std::string input, input_bytes;
  if (c.spec.contains("generate")) {
    input = generate(c.spec, work).string();
    input_bytes = slurp(input);
  }

  std::string cmd = "timeout --signal=KILL " + std::to_string(c.spec.value("timeout", 60)) + " " + LAMINA_EXE;
  // Under scripts/test.sh --sanitize: whole allocation stacks, so that LeakSanitizer can match the
  // third-party leaks of scripts/lsan.supp (OpenImageIO's PNG error path), whose libraries have no
  // frame pointers for the fast unwinder.
  if (const char* asan = std::getenv("ASAN_OPTIONS"))
    cmd = "ASAN_OPTIONS=" + shell_quote(std::string(asan) + ":fast_unwind_on_malloc=0") + " " + cmd;
  for (const json& a : c.spec.at("args")) {
    std::string arg = replace_all(a.get<std::string>(), "{corpus}", LAMINA_CORPUS_DIR);
    arg = replace_all(replace_all(arg, "{out}", out.string()), "{input}", input);
    cmd += " " + shell_quote(arg);
  }
  cmd += " >" + shell_quote((work / "stdout.txt").string()) + " 2>" + shell_quote((work / "stderr.txt").string());
  const int status = std::system(cmd.c_str());
  const int code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  const std::string err = slurp(work / "stderr.txt");
  SCOPED_TRACE(cmd + "\nstderr:\n" + err);

  ASSERT_NE(code, 137) << "killed after the timeout: a hang";
  ASSERT_LT(code, 128) << "ended by signal " << code - 128;
  std::set<int> allowed;
  for (const json& e : c.spec.at("exit")) allowed.insert(e.get<int>());
  EXPECT_TRUE(allowed.count(code)) << "exit status " << code;

  // One error line: the last line, and every other line a warning (or the progress bar).
  std::vector<std::string> lines;
  std::istringstream s(replace_all(err, "\r", "\n"));
  for (std::string l; std::getline(s, l);)
    if (!l.empty()) lines.push_back(l);
  ASSERT_FALSE(lines.empty()) << "no error message";
  for (std::size_t i = 0; i + 1 < lines.size(); ++i)
    EXPECT_TRUE(lines[i].find("warning:") != std::string::npos || lines[i].find('%') != std::string::npos)
        << "more than one error line: " << lines[i];
  EXPECT_NE(lines.back().find(c.spec.at("stderr").get<std::string>()), std::string::npos) << "error line: " << lines.back();
  EXPECT_EQ(lines.back().find("warning:"), std::string::npos) << "the last line is a warning, not the error";

  // An input is never changed, whatever the outputs name (a link to it included).
  if (!input.empty()) EXPECT_TRUE(slurp(input) == input_bytes) << "the input " << input << " was changed";
  if (!c.spec.value("outputs_allowed", false)) {
    for (const auto& e : fs::recursive_directory_iterator(out)) ADD_FAILURE() << "output left behind: " << e.path();
  }
  fs::remove_all(dir);
}

std::string case_name(const ::testing::TestParamInfo<HostileCase>& info) {
  std::string n = info.param.file + "_" + info.param.name;
  for (char& ch : n)
    if (!std::isalnum(static_cast<unsigned char>(ch))) ch = '_';
  return n;
}

INSTANTIATE_TEST_SUITE_P(Corpus, HostileInput, ::testing::ValuesIn(load_cases()), case_name);

}  // namespace
}  // namespace lamina::test
