#include "renderer/scene/scene.h"

#include <cmath>
#include <cstring>

#include <embree3/rtcore.h>
#include <glm/geometric.hpp>

namespace lamina {
namespace {

RTCDevice dev(void* p) { return static_cast<RTCDevice>(p); }
RTCScene scn(void* p) { return static_cast<RTCScene>(p); }

float offset_one(float p, float n) {
  // Waechter and Binder (Ray Tracing Gems ch. 6): move p by a fixed number of ulps (int_scale
  // * n) in its integer representation; near the origin, where ulps are tiny, move by a fixed
  // distance (float_scale * n) instead. Constants from the chapter.
  constexpr float kOrigin = 1.0f / 32.0f;
  constexpr float kFloatScale = 1.0f / 65536.0f;
  constexpr float kIntScale = 256.0f;
  if (std::fabs(p) < kOrigin) return p + kFloatScale * n;
  const auto of = static_cast<std::int32_t>(kIntScale * n);
  std::int32_t bits;
  std::memcpy(&bits, &p, 4);
  bits += (p < 0.0f) ? -of : of;
  float out;
  std::memcpy(&out, &bits, 4);
  return out;
}

// Embree's intersection and occlusion filter for MASK and BLEND meshes: a hit that
// keeps_hit() refuses is invalidated, and Embree goes on to the next one along the ray.
void alpha_filter(const RTCFilterFunctionNArguments* args) {
  const auto* c = static_cast<const AlphaCoverage*>(args->geometryUserPtr);
  for (unsigned i = 0; i < args->N; ++i) {
    if (args->valid[i] != -1) continue;
    const float origin[3] = {RTCRayN_org_x(args->ray, args->N, i), RTCRayN_org_y(args->ray, args->N, i),
                             RTCRayN_org_z(args->ray, args->N, i)};
    const float direction[3] = {RTCRayN_dir_x(args->ray, args->N, i), RTCRayN_dir_y(args->ray, args->N, i),
                                RTCRayN_dir_z(args->ray, args->N, i)};
    if (!keeps_hit(*c, RTCHitN_primID(args->hit, args->N, i), RTCHitN_u(args->hit, args->N, i),
                   RTCHitN_v(args->hit, args->N, i), origin, direction))
      args->valid[i] = 0;
  }
}

}  // namespace

double Scene::coverage(int mesh, int triangle, double b1, double b2) const {
  const int a = alpha_of_mesh_[static_cast<std::size_t>(mesh)];
  return a < 0 ? 1.0 : expected_coverage(alpha_[static_cast<std::size_t>(a)], static_cast<std::uint32_t>(triangle), b1, b2);
}

glm::dvec3 offset_ray_origin(const glm::dvec3& p, const glm::dvec3& n) {
  return {offset_one(static_cast<float>(p.x), static_cast<float>(n.x)),
          offset_one(static_cast<float>(p.y), static_cast<float>(n.y)),
          offset_one(static_cast<float>(p.z), static_cast<float>(n.z))};
}

Scene::Scene(SceneDesc desc) : desc_(std::move(desc)) {
  RTCDevice device = rtcNewDevice(nullptr);
  if (!device) throw SceneError(desc_.path + ": cannot create an Embree device");
  device_ = device;
  RTCScene scene = rtcNewScene(device);
  scene_ = scene;
  alpha_.reserve(desc_.meshes.size());  // no reallocation below: the filters hold pointers
  alpha_of_mesh_.assign(desc_.meshes.size(), -1);
  for (std::size_t i = 0; i < desc_.meshes.size(); ++i) {
    const Mesh& m = desc_.meshes[i];
    RTCGeometry g = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
    // Copied into Embree-owned buffers: shared buffers would need 4 bytes of padding after the
    // last vertex for Embree's 16-byte loads.
    auto* v = static_cast<float*>(rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                                                         3 * sizeof(float), m.positions.size()));
    std::memcpy(v, m.positions.data(), m.positions.size() * 3 * sizeof(float));
    auto* idx = static_cast<unsigned*>(rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                                              3 * sizeof(unsigned), m.indices.size() / 3));
    std::memcpy(idx, m.indices.data(), m.indices.size() * sizeof(unsigned));
    const Material& mat = desc_.material(m.material);
    if (mat.alpha_mode != AlphaMode::kOpaque) {
      AlphaCoverage c;
      c.mesh = &m;
      c.material = &mat;
      if (mat.base_color_texture >= 0 && mat.base_color_texture < static_cast<int>(desc_.textures.size()) &&
          !desc_.textures[mat.base_color_texture].alpha.empty())
        c.texture = &desc_.textures[mat.base_color_texture];
      c.geometry = static_cast<std::uint32_t>(i);
      alpha_of_mesh_[i] = static_cast<int>(alpha_.size());
      alpha_.push_back(c);
      rtcSetGeometryUserData(g, &alpha_.back());
      rtcSetGeometryIntersectFilterFunction(g, &alpha_filter);
      rtcSetGeometryOccludedFilterFunction(g, &alpha_filter);
    }
    rtcCommitGeometry(g);
    rtcAttachGeometryByID(scene, g, static_cast<unsigned>(i));
    rtcReleaseGeometry(g);
  }
  rtcCommitScene(scene);
  if (rtcGetDeviceError(device) != RTC_ERROR_NONE) throw SceneError(desc_.path + ": Embree could not build the scene");
  if (desc_.meshes.empty()) desc_.compute_bounds();
  centre_ = 0.5 * (desc_.bounds_min + desc_.bounds_max);
  radius_ = 0.5 * glm::length(desc_.bounds_max - desc_.bounds_min);
}

Scene::~Scene() {
  if (scene_) rtcReleaseScene(scn(scene_));
  if (device_) rtcReleaseDevice(dev(device_));
}

bool Scene::intersect(const Ray& ray, SurfaceHit* hit, RayCounters& counters, double tmax) const {
  ++counters.closest;
  if (counters.log) counters.log->closest.push_back(ray);
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  RTCRayHit rh;
  rh.ray.org_x = static_cast<float>(ray.origin.x);
  rh.ray.org_y = static_cast<float>(ray.origin.y);
  rh.ray.org_z = static_cast<float>(ray.origin.z);
  rh.ray.dir_x = static_cast<float>(ray.direction.x);
  rh.ray.dir_y = static_cast<float>(ray.direction.y);
  rh.ray.dir_z = static_cast<float>(ray.direction.z);
  rh.ray.tnear = 0.0f;
  rh.ray.tfar = static_cast<float>(std::min(tmax, 3.0e38));
  rh.ray.time = 0.0f;
  rh.ray.mask = 0xFFFFFFFFu;
  rh.ray.id = 0;
  rh.ray.flags = 0;
  rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
  rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
  rtcIntersect1(scn(scene_), &context, &rh);
  if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) return false;

  const Mesh& m = desc_.meshes[rh.hit.geomID];
  const std::uint32_t* tri = &m.indices[3 * static_cast<std::size_t>(rh.hit.primID)];
  const double b1 = rh.hit.u, b2 = rh.hit.v, b0 = 1.0 - b1 - b2;
  const glm::dvec3 p0(m.positions[tri[0]]), p1(m.positions[tri[1]]), p2(m.positions[tri[2]]);
  hit->t = rh.ray.tfar;
  hit->mesh = static_cast<int>(rh.hit.geomID);
  hit->triangle = static_cast<int>(rh.hit.primID);
  hit->p = b0 * p0 + b1 * p1 + b2 * p2;
  hit->ng = glm::normalize(glm::cross(p1 - p0, p2 - p0));
  hit->ns = hit->ng;
  if (!m.normals.empty()) {
    const glm::dvec3 n = b0 * glm::dvec3(m.normals[tri[0]]) + b1 * glm::dvec3(m.normals[tri[1]]) +
                         b2 * glm::dvec3(m.normals[tri[2]]);
    const double len = glm::length(n);
    if (len > 1e-12) hit->ns = n / len;
    // Interpolated normals that point away from the face (bad exports) are mirrored back.
    if (glm::dot(hit->ns, hit->ng) < 0.0) hit->ns = -hit->ns;
  }
  if (!m.texcoords.empty())
    hit->uv = b0 * glm::dvec2(m.texcoords[tri[0]]) + b1 * glm::dvec2(m.texcoords[tri[1]]) +
              b2 * glm::dvec2(m.texcoords[tri[2]]);
  hit->uv1 = glm::dvec2(0.0);
  if (!m.texcoords1.empty())
    hit->uv1 = b0 * glm::dvec2(m.texcoords1[tri[0]]) + b1 * glm::dvec2(m.texcoords1[tri[1]]) +
               b2 * glm::dvec2(m.texcoords1[tri[2]]);
  hit->colour = glm::dvec3(1.0);
  if (!m.colours.empty())
    hit->colour = b0 * glm::dvec3(m.colours[tri[0]]) + b1 * glm::dvec3(m.colours[tri[1]]) + b2 * glm::dvec3(m.colours[tri[2]]);
  hit->tangent = glm::dvec4(0.0);
  if (!m.tangents.empty())
    hit->tangent = b0 * glm::dvec4(m.tangents[tri[0]]) + b1 * glm::dvec4(m.tangents[tri[1]]) +
                   b2 * glm::dvec4(m.tangents[tri[2]]);
  return true;
}

glm::dvec3 normal_mapped(const SurfaceHit& hit, const Texture& map, double scale, glm::dvec2 uv) {
  const glm::dvec3 n = hit.ns;
  glm::dvec3 t(hit.tangent);
  t -= n * glm::dot(n, t);
  const double len = glm::length(t);
  if (!(len > 1e-12)) return n;
  t /= len;
  const glm::dvec3 b = glm::cross(n, t) * (hit.tangent.w < 0.0 ? -1.0 : 1.0);
  const Spectrum texel = map.lookup(uv);
  const glm::dvec3 local((2.0 * texel[0] - 1.0) * scale, (2.0 * texel[1] - 1.0) * scale, 2.0 * texel[2] - 1.0);
  const glm::dvec3 mapped = local.x * t + local.y * b + local.z * n;
  const double m = glm::length(mapped);
  if (!(m > 1e-12) || !std::isfinite(m) || glm::dot(mapped, n) <= 0.0) return n;
  return mapped / m;
}

bool Scene::occluded(const Ray& ray, double tmax, RayCounters& counters) const {
  ++counters.shadow;
  if (counters.log) counters.log->shadow.emplace_back(ray, tmax);
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  RTCRay r;
  r.org_x = static_cast<float>(ray.origin.x);
  r.org_y = static_cast<float>(ray.origin.y);
  r.org_z = static_cast<float>(ray.origin.z);
  r.dir_x = static_cast<float>(ray.direction.x);
  r.dir_y = static_cast<float>(ray.direction.y);
  r.dir_z = static_cast<float>(ray.direction.z);
  r.tnear = 0.0f;
  r.tfar = static_cast<float>(std::min(tmax, 3.0e38));
  r.time = 0.0f;
  r.mask = 0xFFFFFFFFu;
  r.id = 0;
  r.flags = 0;
  rtcOccluded1(scn(scene_), &context, &r);
  return r.tfar < 0.0f;  // Embree sets tfar = -inf on a hit
}

}  // namespace lamina
