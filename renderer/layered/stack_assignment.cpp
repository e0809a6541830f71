#include "renderer/layered/stack_assignment.h"

namespace lamina {

bool parse_stack_assignment(const std::string& text, StackAssignment* out, std::string* why) {
  const std::size_t eq = text.find('=');
  StackAssignment a;
  if (eq == std::string::npos) {
    a.path = text;
  } else {
    a.material = text.substr(0, eq);
    a.path = text.substr(eq + 1);
    if (a.material.empty()) {
      *why = "expected FILE or NAME=FILE (the material name is empty)";
      return false;
    }
  }
  if (a.path.empty()) {
    *why = "expected FILE or NAME=FILE (the file is empty)";
    return false;
  }
  *out = a;
  return true;
}

std::string stack_assignment_text(const StackAssignment& a) { return a.all() ? a.path : a.material + "=" + a.path; }

std::string stack_assignments_text(const std::vector<StackAssignment>& list) {
  std::string s;
  for (const StackAssignment& a : list) s += (s.empty() ? "" : "; ") + stack_assignment_text(a);
  return s;
}

}  // namespace lamina
