// Which glTF materials are layered (docs/materials.md, "Binding a stack to a glTF material"): a glTF material
// names its stack file in its extras, {"lamina": {"stack": "skin.json"}} (Blender exports custom
// properties there), or a material map given by `lamina render --materials MAP.json` maps glTF
// material names to stack files: {"Skin": "materials/skin.json", ...}. A relative path resolves
// against the directory of the file that names it (the glTF, or the map). The map wins over
// extras. Texture-driven parameters: docs/stack_bindings.md.
#pragma once

#include <string>
#include <vector>

#include "renderer/layered/layered_material.h"
#include "renderer/layered/stack_assignment.h"

namespace lamina {

struct SceneDesc;

// A stack given in memory instead of a file (lamina batch's variants): as if a material map
// named the file `source` holding `json` for glTF material `material`.
struct InlineStack {
  std::string material;  // glTF material name
  std::string json;      // the stack file's text
  std::string source;    // the name it goes by in messages and LayeredMaterial::source()
};

// Binds stacks to the scene's materials: the map file (if not empty) first, then each
// material's extras["lamina.stack"]. A map entry may also be an object {"stack": ..., "bind":
// [...], "freckles": {...}}, and the extras' "lamina" object may hold "bind" and "freckles":
// texture-driven parameters (renderer/layered/stack_bindings.h). Throws SceneError with one line naming the glTF (or map)
// and the stack file: a missing stack file, a map naming no material of the scene, or the
// StackFileError message of a bad stack file.
// `inline_stacks` win over the map and the extras; a name that is no material of the scene is an
// error, as in the map.
// `stacks` (--stack, stack_assignment.h) win over the map and the extras (named ones over the
// one for all); a name that is no material of the scene is an error listing the scene's names.
// spectral: the spectral mode, which also reads stack files with leaf layers (wavelength_stack.h).
LayeredBindings bind_layered_materials(const SceneDesc& scene, const std::string& materials_map_path,
                                       const std::vector<InlineStack>& inline_stacks = {},
                                       const std::vector<StackAssignment>& stacks = {}, bool spectral = false);

// With a --stack for every material: the meshes without a material get one, kNoMaterialName (the
// default material's Lambert 0.8 until the stack replaces it), so the stack reaches them too.
void adopt_meshes_without_material(const std::vector<StackAssignment>& stacks, SceneDesc* scene);

}  // namespace lamina
