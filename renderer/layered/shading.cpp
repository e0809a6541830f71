#include "renderer/layered/shading.h"

#include <optional>

#include <glm/geometric.hpp>

#include "materials/walk/random_walk.h"
#include "renderer/layered/layered_shading.h"
#include "renderer/layered/layered_tables.h"
#include "renderer/layered/spectral_tables.h"
#include "renderer/layered/stack_bindings.h"
#include "renderer/layered/wavelength_stack.h"
#include "renderer/surfaces/first_order_surface.h"
#include "renderer/surfaces/metallic_roughness_surface.h"
#include "renderer/surfaces/random_walk_surface.h"
#include "renderer/surfaces/table_surface.h"

namespace lamina {
namespace {

// Shade both sides of every surface: turn the normals towards the viewer. Returns whether the
// viewer is on the back side of the geometric normal.
bool shading_geometry(const SceneDesc& desc, const SurfaceHit& hit, const Material& mat, const glm::dvec3& wo_world,
                      ShadingGeometry* g) {
  glm::dvec3 ng = hit.ng, ns = hit.ns;
  if (mat.normal_texture >= 0 && hit.tangent != glm::dvec4(0.0))
    ns = normal_mapped(hit, desc.textures[mat.normal_texture], mat.normal_scale, texture_uv(mat.normal_uv, hit));
  const bool back_side = glm::dot(ng, wo_world) < 0.0;
  if (back_side) {
    ng = -ng;
    ns = -ns;
  }
  // A shading normal that puts the viewer below the surface is unusable here: use ng.
  if (glm::dot(ns, wo_world) <= 0.0) ns = ng;
  g->ng = ng;
  g->frame = Frame(ns);
  g->wo = g->frame.to_local(wo_world);
  return back_side;
}

// A material that is not layered: Lambert with the base colour (its texture and the vertex
// colours multiplied in), or, for a glTF material, its metallic-roughness BRDF (Appendix B), with
// the metallicRoughnessTexture's B (metalness) and G (roughness) multiplied in. In the spectral
// mode the base colour (the product of its factors, the colour the RGB mode reflects) is uplifted
// to the path's wavelengths; the metal's Fresnel of F0 = base colour then acts per wavelength.
const Surface& plain_surface(const SceneDesc& desc, const SurfaceHit& hit, const Material& mat,
                             const SampledWavelengths* wavelengths, SurfaceStorage& storage) {
  Spectrum albedo = mat.base_color;
  if (mat.base_color_texture >= 0) albedo *= desc.textures[mat.base_color_texture].lookup(texture_uv(mat.base_color_uv, hit));
  albedo *= Spectrum(hit.colour.x, hit.colour.y, hit.colour.z);
  if (wavelengths) albedo = wavelengths->reflectance(albedo);
  if (!mat.metallic_roughness) return storage.emplace<LambertSurface>(albedo);
  double metallic = mat.metallic, roughness = mat.roughness;
  if (mat.metallic_roughness_texture >= 0) {
    const Spectrum t = desc.textures[mat.metallic_roughness_texture].lookup(texture_uv(mat.metallic_roughness_uv, hit));
    roughness *= t[1];
    metallic *= t[2];
  }
  return storage.emplace<MetallicRoughnessSurface>(albedo, metallic, roughness);
}

// A table surface with the factors of its texture-driven parameters and, in the spectral mode,
// its grid tables at the path's wavelengths (they live as long as it).
struct FactoredTable {
  TableFactor factors[LayeredTables::kMaxFactors];
  SpectralTableChannels spectral;
  std::optional<TableSurface> surface;
};

// table mode: texture-driven parameters scale the table's bins (renderer/layered/layered_tables.h);
// in the spectral mode (w not null) the grid tables give the bins (renderer/layered/spectral_tables.h).
const Surface& table_surface(const LayeredShading& layered, const LayeredMaterial& lm, const ShadingPoint& sp,
                             const LayerStack& stack, const glm::dvec3& wo, const SampledWavelengths* w,
                             SurfaceStorage& storage) {
  const LayeredTables& tables = *layered.tables;
  FactoredTable& t = storage.emplace<FactoredTable>();
  int factor_count = 0;
  if (const StackBindings* b = lm.bindings(); b && !b->empty()) {
    ParameterValues values(b->parameters().size());
    b->values(sp.uv, values.data());
    factor_count = tables.factors(&lm, sp.from_below, values.data(), t.factors);
  }
  if (w) layered.spectral_tables->channels(&lm, sp.from_below, *w, &t.spectral);
  return t.surface.emplace(tables.get(&lm, sp.from_below), stack, wo, t.factors, factor_count, w ? &t.spectral : nullptr);
}

}  // namespace

PathShading Shading::start_path(std::uint64_t seed, std::uint64_t pixel, std::uint64_t sample,
                                std::uint64_t* events) const {
  PathShading path;
  path.strata_ = HeroStrata{seed, pixel, sample};
  path.stratified_ = layered_ && layered_->test_hooks.stratified_hero;
  path.events_ = events;
  path.spectral_ = spectral_;
  if (spectral_) path.wavelengths_ = SampledWavelengths::for_sample(seed, pixel, sample);
  return path;
}

const Surface& Shading::surface_at(const SurfaceHit& hit, const glm::dvec3& wo_world, PathShading& path,
                                   SurfaceStorage& storage, ShadingGeometry* geometry) const {
  thread_local StackScratch scratch;  // stack_at() may build a stack per hit here
  const int material_index = desc_.meshes[hit.mesh].material;
  const Material& mat = desc_.material(material_index);
  const bool back_side = shading_geometry(desc_, hit, mat, wo_world, geometry);
  const LayeredMaterial* lm = layered_ && layered_->bindings ? layered_->bindings->get(material_index) : nullptr;
  if (!lm) return plain_surface(desc_, hit, mat, path.wavelengths(), storage);
  const SubsurfaceMode mode = layered_->mode_for(material_index);
  const SampledWavelengths* w = path.wavelengths();
  if (mode == SubsurfaceMode::Lambert)
    return storage.emplace<LambertSurface>(w ? layered_->spectral_tables->lambert_albedo(*lm, hit.uv, *w) : lm->lambert_albedo_at(hit.uv));
  // The top faces the viewer: a transmitting stack seen from behind is flipped; any other
  // stack is seen from its top from either side (closed meshes).
  ShadingPoint sp;
  sp.p = hit.p;
  sp.uv = hit.uv;
  sp.mesh = hit.mesh;
  sp.triangle = hit.triangle;
  sp.from_below = back_side && lm->transmits();
  const LayerStack* stack = &lm->stack_at(sp, scratch);
  if (w) {  // the spectral mode: the stack at the path's wavelengths
    thread_local LayerStack at_wavelengths;  // like `scratch`: valid until the next hit of this thread
    const SpectralStack* spectral = layered_->spectral_for(material_index);
    if (const StackBindings* b = lm->bindings(); spectral && b && !b->empty()) {
      thread_local SpectralStack bound;  // the chromophores bound at this hit
      bind_chromophores(*spectral, *b, sp.uv, &bound);
      spectral = &bound;
    }
    // Leaf layers are walked (shading preparation refuses the other modes for them).
    if ((spectral && has_leaf_layers(*spectral)) || layered_->test_hooks.one_wavelength_walks)
      return one_wavelength_walk(*stack, spectral, sp.from_below, *w, path, storage);
    stack_at_wavelengths(*stack, spectral, sp.from_below, *w, &at_wavelengths);
    stack = &at_wavelengths;
  }
  switch (mode) {
    case SubsurfaceMode::FirstOrder:
      return storage.emplace<FirstOrderSurface>(*stack, geometry->wo);
    case SubsurfaceMode::Table:
      return table_surface(*layered_, *lm, sp, *stack, geometry->wo, w, storage);
    case SubsurfaceMode::RandomWalk:
    case SubsurfaceMode::Lambert:
      break;
  }
  const int hero = path.stratified_ ? path.strata_.hero(path.walks_) : kRandomHero;
  ++path.walks_;
  return storage.emplace<RandomWalkSurface>(*stack, hero, layered_->walk, path.events_);
}

// The index varies with the wavelength: the path follows one wavelength from here on, the
// first such walk's stratified hero (uniform on the three channels, independent of the
// wavelengths). At that first hit one walk per wavelength gives each channel's light
// connections and the followed one continues, weight 3 in its channel, 0 in the others;
// later such hits walk at the followed wavelength alone (docs/spectral.md, "Leaves: one
// wavelength through a leaf").
const Surface& Shading::one_wavelength_walk(const LayerStack& stack, const SpectralStack* spectral, bool from_below,
                                            const SampledWavelengths& w, PathShading& path,
                                            SurfaceStorage& storage) const {
  const int walk_index = path.walks_++;
  if (path.one_wavelength_ < 0) {
    path.one_wavelength_ = path.strata_.hero(walk_index);
    thread_local LayerStack at_each[kChannels];  // valid until the next hit of this thread
    for (int c = 0; c < kChannels; ++c) stack_at_wavelength_channel(stack, spectral, from_below, w, c, &at_each[c]);
    return storage.emplace<WavelengthWalksSurface>(at_each, path.one_wavelength_, layered_->walk, path.events_);
  }
  thread_local LayerStack at_wavelength;
  stack_at_wavelength_channel(stack, spectral, from_below, w, path.one_wavelength_, &at_wavelength);
  RandomWalkSurface& s = storage.emplace<RandomWalkSurface>(at_wavelength, path.one_wavelength_, layered_->walk, path.events_);
  s.follow_one_wavelength(path.one_wavelength_, 1.0);
  return s;
}

}  // namespace lamina
