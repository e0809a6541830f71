// Nesting depth of JSON text, before parsing (see json_limits.h).
#include "materials/stack/json_limits.h"

#include <string>
#include <vector>

namespace lamina {

std::optional<std::size_t> json_nesting_exceeds(std::string_view text, int max_depth) {
  int depth = 0;
  bool in_string = false;
  for (std::size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (in_string) {
      if (c == '\\') ++i;  // the escaped character (", \, /, b, f, n, r, t or u) cannot end the string
      else if (c == '"') in_string = false;
      continue;
    }
    if (c == '"') {
      in_string = true;
    } else if (c == '[' || c == '{') {
      if (++depth > max_depth) return i;
    } else if (c == ']' || c == '}') {
      // An unbalanced close is the parser's error to report; never let it make room for more.
      if (depth > 0) --depth;
    }
  }
  return std::nullopt;
}

std::string json_nesting_message(std::size_t offset, int max_depth) {
  return "JSON nested deeper than " + std::to_string(max_depth) + " levels (at byte " + std::to_string(offset) + ")";
}

namespace {

// Where nlohmann's parser is in the document, from its callback's events: one frame per open
// array or object, with the array's count of finished elements or the object's last key.
class JsonPathTracker {
 public:
  bool event(nlohmann::json::parse_event_t e, const nlohmann::json& parsed) {
    using E = nlohmann::json::parse_event_t;
    switch (e) {
      case E::object_start: frames_.push_back({false, 0, ""}); break;
      case E::array_start: frames_.push_back({true, 0, ""}); break;
      case E::key: frames_.back().key = parsed.get<std::string>(); break;
      case E::object_end:
      case E::array_end:
        frames_.pop_back();
        element_done();
        break;
      case E::value: element_done(); break;
    }
    return true;
  }
  std::string path() const {
    std::string p;
    for (const Frame& f : frames_)
      p += f.array ? "[" + std::to_string(f.index) + "]" : (p.empty() ? "" : ".") + f.key;
    return p;
  }

 private:
  struct Frame {
    bool array;
    std::size_t index;
    std::string key;
  };
  void element_done() {
    if (!frames_.empty() && frames_.back().array) ++frames_.back().index;
  }
  std::vector<Frame> frames_;
};

// nlohmann's message without its "[json.exception.NAME.ID] " tag.
std::string without_tag(const std::string& what) {
  const std::size_t close = what.find("] ");
  return what.rfind("[json.exception.", 0) == 0 && close != std::string::npos ? what.substr(close + 2) : what;
}

}  // namespace

// nlohmann's callback parser, which the path tracker needs, searches the enclosing array at every
// object's end (quadratic in an array's length: 8 s for a glTF of 100 000 nodes), so a document
// is parsed without it, and parsed again with it only to say where the first one failed.
std::string parse_json_text(std::string_view text, nlohmann::json* out, std::string* path) {
  if (path) path->clear();
  if (const auto deep = json_nesting_exceeds(text)) return json_nesting_message(*deep);
  try {
    *out = nlohmann::json::parse(text.begin(), text.end());
    return "";
  } catch (const nlohmann::json::exception&) {
  }
  JsonPathTracker tracker;
  std::string reason;
  try {
    *out = nlohmann::json::parse(text.begin(), text.end(), [&tracker](int, nlohmann::json::parse_event_t e, nlohmann::json& parsed) {
      return tracker.event(e, parsed);
    });
    return "";  // not reached: the same text fails the same way
  } catch (const nlohmann::json::parse_error& e) {
    return "malformed JSON: " + without_tag(e.what());  // names line and column
  } catch (const nlohmann::json::out_of_range& e) {
    // 406: a number beyond the largest double ("number overflow parsing '1e999'").
    reason = without_tag(e.what());
    const std::string prefix = "number overflow parsing ";
    if (e.id == 406 && reason.rfind(prefix, 0) == 0)
      reason = "number " + reason.substr(prefix.size()) + " is too large for a double (at most 1.79769e+308)";
  } catch (const nlohmann::json::exception& e) {
    reason = "malformed JSON: " + without_tag(e.what());
  }
  const std::string where = tracker.path();
  if (path) {
    *path = where;
    return reason;
  }
  return (where.empty() ? "" : where + ": ") + reason;
}

}  // namespace lamina
