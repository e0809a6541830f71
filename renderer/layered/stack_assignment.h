// `lamina render --stack`: a stack file assigned from the command line, without editing the glTF
// (docs/materials.md, "Assigning a stack from the command line"). Declared here once: the flag,
// its help, its parsing and the EXR header key all come from this file.
//   --stack FILE        every material of the scene, and every mesh without a material
//   --stack NAME=FILE   the glTF material NAME (repeatable; named assignments win over FILE)
// Precedence over the other ways to bind a stack (renderer/layered/material_binding.h): a named
// --stack, then --stack FILE, then --materials, then the material's extras, then its glTF
// transmission extensions.
#pragma once

#include <string>
#include <vector>

namespace lamina {

struct StackAssignment {
  std::string material;  // "" for every material (and the meshes without one)
  std::string path;      // the stack file, relative to the working directory
  bool all() const { return material.empty(); }
};

inline constexpr const char* kStackFlag = "--stack";
inline constexpr const char* kStackHelp =
    "a stack file for every material and mesh (--stack FILE) or for one glTF material (--stack NAME=FILE); "
    "repeatable, names win";
// The header key: the assignments as given, joined by "; " (only when --stack is given).
inline constexpr const char* kStackExrKey = "lamina:stack";

// Reads "FILE" or "NAME=FILE" (split at the first '='). False, with *why, for an empty name or
// file.
bool parse_stack_assignment(const std::string& text, StackAssignment* out, std::string* why);
// The assignment as --stack takes it.
std::string stack_assignment_text(const StackAssignment& a);
std::string stack_assignments_text(const std::vector<StackAssignment>& list);

// The name given to the material of meshes that have none when --stack FILE adopts them.
inline constexpr const char* kNoMaterialName = "(no material)";

}  // namespace lamina
