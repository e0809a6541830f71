#include "renderer/image/denoise.h"

#include <dlfcn.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <vector>

namespace lamina {
namespace {

// The part of OIDN 2.x's C API (include/OpenImageDenoise/oidn.h, Apache-2.0) that Lamina calls,
// declared from its documentation: opaque handles, and the enum values that cross the ABI.
using OIDNDevice = struct OIDNDeviceImpl*;
using OIDNFilter = struct OIDNFilterImpl*;
constexpr int kOidnDeviceTypeCpu = 1;  // OIDN_DEVICE_TYPE_CPU
constexpr int kOidnFormatFloat3 = 3;   // OIDN_FORMAT_FLOAT3
constexpr int kOidnErrorNone = 0;      // OIDN_ERROR_NONE

struct OidnApi {
  void* handle = nullptr;
  std::string path;
  OIDNDevice (*new_device)(int) = nullptr;
  void (*set_device_int)(OIDNDevice, const char*, int) = nullptr;
  int (*get_device_int)(OIDNDevice, const char*) = nullptr;
  void (*commit_device)(OIDNDevice) = nullptr;
  void (*release_device)(OIDNDevice) = nullptr;
  int (*get_device_error)(OIDNDevice, const char**) = nullptr;
  OIDNFilter (*new_filter)(OIDNDevice, const char*) = nullptr;
  void (*set_shared_filter_image)(OIDNFilter, const char*, void*, int, std::size_t, std::size_t, std::size_t, std::size_t,
                                  std::size_t) = nullptr;
  void (*set_filter_bool)(OIDNFilter, const char*, bool) = nullptr;
  void (*commit_filter)(OIDNFilter) = nullptr;
  void (*execute_filter)(OIDNFilter) = nullptr;
  void (*release_filter)(OIDNFilter) = nullptr;
};

std::vector<std::string> candidates() {
  std::vector<std::string> paths;
  if (const char* env = std::getenv("LAMINA_OIDN_LIBRARY"); env && *env) return {env};  // the user's choice, only
#ifdef LAMINA_OIDN_DEFAULT
  if (*LAMINA_OIDN_DEFAULT) paths.emplace_back(LAMINA_OIDN_DEFAULT);
#endif
  paths.emplace_back("libOpenImageDenoise.so.2");
  return paths;
}

template <typename F>
void bind(void* handle, const char* name, const std::string& path, F* out) {
  void* symbol = ::dlsym(handle, name);
  if (!symbol) throw DenoiseError("'" + path + "' has no " + name + " (not Open Image Denoise 2.x?)");
  *out = reinterpret_cast<F>(symbol);
}

// Loaded once per process; never unloaded (OIDN keeps threads and kernels alive).
const OidnApi& oidn() {
  static const OidnApi api = [] {
    OidnApi a;
    std::string tried;
    for (const std::string& path : candidates()) {
      a.handle = ::dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);
      if (a.handle) {
        a.path = path;
        break;
      }
      const char* why = ::dlerror();
      tried += (tried.empty() ? "" : "; ") + std::string(why ? why : path.c_str());
    }
    if (!a.handle)
      throw DenoiseError("Open Image Denoise not found (" + tried +
                         "): run scripts/setup.sh (pip pyoidn) or set LAMINA_OIDN_LIBRARY to libOpenImageDenoise.so.2");
    bind(a.handle, "oidnNewDevice", a.path, &a.new_device);
    bind(a.handle, "oidnSetDeviceInt", a.path, &a.set_device_int);
    bind(a.handle, "oidnGetDeviceInt", a.path, &a.get_device_int);
    bind(a.handle, "oidnCommitDevice", a.path, &a.commit_device);
    bind(a.handle, "oidnReleaseDevice", a.path, &a.release_device);
    bind(a.handle, "oidnGetDeviceError", a.path, &a.get_device_error);
    bind(a.handle, "oidnNewFilter", a.path, &a.new_filter);
    bind(a.handle, "oidnSetSharedFilterImage", a.path, &a.set_shared_filter_image);
    bind(a.handle, "oidnSetFilterBool", a.path, &a.set_filter_bool);
    bind(a.handle, "oidnCommitFilter", a.path, &a.commit_filter);
    bind(a.handle, "oidnExecuteFilter", a.path, &a.execute_filter);
    bind(a.handle, "oidnReleaseFilter", a.path, &a.release_filter);
    return a;
  }();
  return api;
}

}  // namespace

std::string oidn_library_candidates() {
  std::string list;
  for (const std::string& p : candidates()) list += (list.empty() ? "" : ", ") + p;
  return list;
}

DenoiseResult denoise(const DenoiseInput& in) {
  if (!in.colour || in.colour->rgb.empty()) throw DenoiseError("no colour image to denoise");
  const int w = in.colour->width, h = in.colour->height;
  auto same_size = [&](const Image* aux, const char* what) {
    if (aux && (aux->width != w || aux->height != h)) throw DenoiseError(std::string(what) + " image differs in size from the colour");
  };
  same_size(in.albedo, "albedo");
  same_size(in.normal, "normal");
  if (in.normal && !in.albedo) throw DenoiseError("a normal image needs an albedo image too (OIDN's RT filter)");

  const OidnApi& api = oidn();
  // OIDN reads and writes through these (shared images: no copies inside the library).
  std::vector<float> colour = in.colour->rgb, albedo, normal;
  for (float& v : colour) v = std::isfinite(v) ? std::max(v, 0.0f) : 0.0f;
  if (in.albedo) {
    albedo = in.albedo->rgb;
    for (float& v : albedo) v = std::isfinite(v) ? std::clamp(v, 0.0f, 1.0f) : 0.0f;
  }
  if (in.normal) {
    normal = in.normal->rgb;
    for (float& v : normal) v = std::isfinite(v) ? std::clamp(v, -1.0f, 1.0f) : 0.0f;
  }
  DenoiseResult result;
  result.image = Image(w, h);
  result.library = api.path;

  OIDNDevice device = api.new_device(kOidnDeviceTypeCpu);
  if (!device) throw DenoiseError("Open Image Denoise (" + api.path + ") could not create a CPU device");
  struct Release {
    const OidnApi& api;
    OIDNDevice device;
    OIDNFilter filter = nullptr;
    ~Release() {
      if (filter) api.release_filter(filter);
      api.release_device(device);
    }
  } release{api, device};
  auto check = [&](const char* step) {
    const char* message = nullptr;
    if (api.get_device_error(device, &message) != kOidnErrorNone)
      throw DenoiseError(std::string("Open Image Denoise: ") + step + ": " + (message ? message : "error"));
  };
  if (in.threads > 0) api.set_device_int(device, "numThreads", in.threads);
  api.commit_device(device);
  check("device");
  result.version = api.get_device_int(device, "version");
  release.filter = api.new_filter(device, "RT");
  check("filter");
  auto image = [&](const char* name, std::vector<float>& data) {
    api.set_shared_filter_image(release.filter, name, data.data(), kOidnFormatFloat3, static_cast<std::size_t>(w),
                                static_cast<std::size_t>(h), 0, 0, 0);
  };
  image("color", colour);
  if (in.albedo) image("albedo", albedo);
  if (in.normal) image("normal", normal);
  image("output", result.image.rgb);
  api.set_filter_bool(release.filter, "hdr", true);
  api.commit_filter(release.filter);
  check("filter settings");
  api.execute_filter(release.filter);
  check("denoising");
  return result;
}

}  // namespace lamina
