#include "renderer/render/lights.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <glm/geometric.hpp>

#include "materials/base/sampling.h"

namespace lamina {
namespace {

// Isotropic point light of radiant intensity I (W/sr): Li = I / d^2 (pbrt-v4 12.2.1).
class PointLight final : public Light {
 public:
  explicit PointLight(const LightDesc& d) : d_(d) {}
  bool sample_li(const glm::dvec3& p, glm::dvec2, LightSample* s) const override {
    const glm::dvec3 v = d_.position - p;
    const double d2 = glm::dot(v, v);
    if (!(d2 > 0.0)) return false;
    s->wi = v / std::sqrt(d2);
    s->li = d_.intensity * (falloff(-s->wi) / d2);
    s->target = d_.position;
    s->infinite = false;
    s->pdf = 1.0;
    return !s->li.is_black();
  }
  double pdf_li(const glm::dvec3&, const glm::dvec3&, const SurfaceHit*) const override { return 0.0; }
  bool is_delta() const override { return true; }
  double power() const override {
    if (d_.type == LightType::kPoint) return 4.0 * kPi * d_.intensity.average();
    // Spot: the solid angle of the cone out to halfway through the falloff, 2 pi (1 - cos),
    // as pbrt-v4 12.2.2 approximates it (used only to choose lights).
    return 2.0 * kPi * (1.0 - 0.5 * (d_.cos_inner + d_.cos_outer)) * d_.intensity.average();
  }

 private:
  // Spot falloff of KHR_lights_punctual's implementation note: a quadratic ramp in cos(theta)
  // from the outer to the inner cone, t = clamp((cos - cos_outer) / (cos_inner - cos_outer)),
  // attenuation t^2. Point lights: 1.
  double falloff(const glm::dvec3& w_from_light) const {
    if (d_.type != LightType::kSpot) return 1.0;
    const double c = glm::dot(w_from_light, d_.direction);
    const double t = std::clamp((c - d_.cos_outer) / std::max(1e-3, d_.cos_inner - d_.cos_outer), 0.0, 1.0);
    return t * t;
  }
  LightDesc d_;
};

// Directional light of irradiance E (W/m^2) on a surface facing it: Li = E per delta
// direction (pbrt-v4 12.4). Power: E times the scene's cross-section pi r^2.
class DirectionalLight final : public Light {
 public:
  DirectionalLight(const LightDesc& d, double radius) : d_(d), radius_(radius) {}
  bool sample_li(const glm::dvec3&, glm::dvec2, LightSample* s) const override {
    s->wi = -d_.direction;
    s->li = d_.intensity;
    s->infinite = true;
    s->pdf = 1.0;
    return !s->li.is_black();
  }
  double pdf_li(const glm::dvec3&, const glm::dvec3&, const SurfaceHit*) const override { return 0.0; }
  bool is_delta() const override { return true; }
  double power() const override { return kPi * radius_ * radius_ * d_.intensity.average(); }

 private:
  LightDesc d_;
  double radius_;
};

// An emissive triangle, sampled uniformly by area and converted to solid angle with
// pdf_w = d^2 / (|cos theta_light| A) (pbrt-v4 6.5.4 and 12.3).
class TriangleLight final : public Light {
 public:
  TriangleLight(const Scene& scene, int mesh, int triangle) : scene_(scene), mesh_(mesh), triangle_(triangle) {
    const Mesh& m = scene.desc().meshes[mesh];
    const std::uint32_t* t = &m.indices[3 * static_cast<std::size_t>(triangle)];
    for (int k = 0; k < 3; ++k) {
      p_[k] = glm::dvec3(m.positions[t[k]]);
      if (!m.texcoords.empty()) uv_[k] = glm::dvec2(m.texcoords[t[k]]);
      if (!m.texcoords1.empty()) uv1_[k] = glm::dvec2(m.texcoords1[t[k]]);
    }
    const glm::dvec3 c = glm::cross(p_[1] - p_[0], p_[2] - p_[0]);
    area_ = 0.5 * glm::length(c);
    n_ = c / (2.0 * area_);
    const Material& mat = scene.desc().material(m.material);
    two_sided_ = mat.double_sided;
    emission_ = mat.emission;
  }
  bool sample_li(const glm::dvec3& p, glm::dvec2 u, LightSample* s) const override {
    // Uniform barycentrics: b0 = 1 - sqrt(u0), b1 = u1 sqrt(u0) (pbrt-v4 A.5.5, "SampleUniformTriangle").
    const double su = std::sqrt(u.x);
    const double b0 = 1.0 - su, b1 = u.y * su, b2 = 1.0 - b0 - b1;
    SurfaceHit h;
    h.p = b0 * p_[0] + b1 * p_[1] + b2 * p_[2];
    h.ng = n_;
    h.uv = b0 * uv_[0] + b1 * uv_[1] + b2 * uv_[2];
    h.uv1 = b0 * uv1_[0] + b1 * uv1_[1] + b2 * uv1_[2];
    h.mesh = mesh_;
    h.triangle = triangle_;
    const glm::dvec3 v = h.p - p;
    const double d2 = glm::dot(v, v);
    if (!(d2 > 0.0)) return false;
    s->wi = v / std::sqrt(d2);
    const double cos_light = std::abs(glm::dot(n_, s->wi));
    if (!(cos_light > 0.0)) return false;
    // An alpha-cut emitter (MASK, BLEND) emits only where rays meet it: the light at the sampled
    // point times the probability a ray keeps a hit there, as BSDF-sampled rays see it on average.
    s->li = emitted_radiance(scene_, h, -s->wi) * scene_.coverage(mesh_, triangle_, b1, b2);
    if (s->li.is_black()) return false;
    s->pdf = d2 / (cos_light * area_);
    s->target = offset_ray_origin(h.p, glm::dot(n_, s->wi) < 0.0 ? n_ : -n_);
    s->infinite = false;
    return std::isfinite(s->pdf);
  }
  double pdf_li(const glm::dvec3&, const glm::dvec3& wi, const SurfaceHit* hit) const override {
    if (!hit) return 0.0;
    const double cos_light = std::abs(glm::dot(hit->ng, wi));
    return cos_light > 0.0 ? hit->t * hit->t / (cos_light * area_) : 0.0;
  }
  bool is_delta() const override { return false; }
  // Lambertian emitter: power = pi A Le per emitting side (the texture's variation ignored).
  double power() const override { return (two_sided_ ? 2.0 : 1.0) * kPi * area_ * emission_.average(); }

 private:
  const Scene& scene_;
  int mesh_, triangle_;
  glm::dvec3 p_[3];
  glm::dvec2 uv_[3]{}, uv1_[3]{};
  glm::dvec3 n_;
  double area_ = 0.0;
  bool two_sided_ = false;
  Spectrum emission_;
};

// The environment (environment.h) as a light: its own importance sampling.
class EnvironmentLight final : public Light {
 public:
  EnvironmentLight(const EnvironmentMap& env, double radius) : env_(env), radius_(radius) {}
  bool sample_li(const glm::dvec3&, glm::dvec2 u, LightSample* s) const override {
    s->li = env_.sample(u, &s->wi, &s->pdf);
    s->infinite = true;
    return s->pdf > 0.0 && !s->li.is_black();
  }
  double pdf_li(const glm::dvec3&, const glm::dvec3& wi, const SurfaceHit* hit) const override {
    return hit ? 0.0 : env_.pdf(wi);
  }
  bool is_delta() const override { return false; }
  // Power = pi r^2 x integral of L over the sphere; the integral is estimated from 256
  // directions of a Fibonacci sphere (only chooses lights, so an estimate is enough).
  double power() const override {
    const int n = 256;
    double sum = 0.0;
    for (int i = 0; i < n; ++i) {
      const double z = 1.0 - (2.0 * i + 1.0) / n;
      const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
      const double phi = i * kPi * (3.0 - std::sqrt(5.0));
      sum += env_.eval({r * std::cos(phi), z, r * std::sin(phi)}).average();
    }
    return kPi * radius_ * radius_ * 4.0 * kPi * sum / n;
  }

 private:
  const EnvironmentMap& env_;
  double radius_;
};

}  // namespace

Spectrum emitted_radiance(const Scene& scene, const SurfaceHit& hit, const glm::dvec3& w) {
  const SceneDesc& d = scene.desc();
  const Material& mat = d.material(d.meshes[hit.mesh].material);
  if (mat.emission.is_black()) return Spectrum(0.0);
  if (!mat.double_sided && glm::dot(hit.ng, w) <= 0.0) return Spectrum(0.0);
  Spectrum le = mat.emission;
  if (mat.emissive_texture >= 0) le *= d.textures[mat.emissive_texture].lookup(texture_uv(mat.emissive_uv, hit));
  return le;
}

LightSet::LightSet(const Scene& scene, const EnvironmentMap& environment) : environment_map_(environment) {
  const SceneDesc& d = scene.desc();
  for (const LightDesc& l : d.lights) {
    if (l.type == LightType::kDirectional)
      lights_.push_back(std::make_unique<DirectionalLight>(l, scene.radius()));
    else
      lights_.push_back(std::make_unique<PointLight>(l));
  }
  triangle_light_.resize(d.meshes.size());
  for (std::size_t m = 0; m < d.meshes.size(); ++m) {
    const std::size_t n = d.meshes[m].indices.size() / 3;
    triangle_light_[m].assign(d.material(d.meshes[m].material).emission.is_black() ? 0 : n, -1);
    for (std::size_t t = 0; t < triangle_light_[m].size(); ++t) {
      triangle_light_[m][t] = static_cast<int>(lights_.size());
      lights_.push_back(std::make_unique<TriangleLight>(scene, static_cast<int>(m), static_cast<int>(t)));
    }
  }
  if (!environment_map_.is_black()) {
    lights_.push_back(std::make_unique<EnvironmentLight>(environment_map_, scene.radius()));
    environment_ = lights_.back().get();
  }
  std::size_t delta_lights = 0;
  for (std::size_t i = 0; i < lights_.size(); ++i) {
    lights_[i]->id = i;
    delta_lights += lights_[i]->is_delta();
  }
  const bool each_delta = delta_lights <= kMaxLightsSampledEach;
  std::vector<double> power;
  for (const std::unique_ptr<Light>& light : lights_) {
    const double p = light->power();
    const bool emits = std::isfinite(p) && p > 0.0;
    if (each_delta && light->is_delta()) {
      if (emits) sampled_each_.push_back(light.get());
      continue;
    }
    pool_.push_back(light.get());
    power.push_back(emits ? p : 0.0);
  }
  pmf_.assign(lights_.size(), 0.0);
  if (!pool_.empty()) {
    distribution_ = Distribution1D(power);
    for (std::size_t i = 0; i < pool_.size(); ++i) pmf_[pool_[i]->id] = distribution_.pmf(i);
  }
}

const Light* LightSet::choose(double u, double* pmf) const {
  if (pool_.empty()) return nullptr;
  const std::size_t i = distribution_.sample_discrete(u, pmf);
  return pool_[i];
}

double LightSet::pmf(const Light* light) const { return pmf_[light->id]; }

const Light* LightSet::triangle_light(int mesh, int triangle) const {
  const std::vector<int>& v = triangle_light_[mesh];
  return v.empty() ? nullptr : lights_[v[triangle]].get();
}

}  // namespace lamina
