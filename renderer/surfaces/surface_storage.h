// Room for the Surface of one hit, built in place by the shading library
// (renderer/layered/shading.h): the integrator holds it without knowing its kind, and no hit
// allocates.
#pragma once

#include <cstddef>
#include <new>
#include <utility>

namespace lamina {

class SurfaceStorage {
 public:
  // The largest surface with its data (a table surface with its factors) fits.
  static constexpr std::size_t kBytes = 1280;

  SurfaceStorage() = default;
  SurfaceStorage(const SurfaceStorage&) = delete;
  SurfaceStorage& operator=(const SurfaceStorage&) = delete;
  ~SurfaceStorage() { reset(); }

  // Builds a T in the storage (destroying what it held) and returns it.
  template <class T, class... Args>
  T& emplace(Args&&... args) {
    static_assert(sizeof(T) <= kBytes, "SurfaceStorage::kBytes is too small for this surface");
    static_assert(alignof(T) <= alignof(std::max_align_t), "over-aligned surface");
    reset();
    T* held = new (bytes_) T(std::forward<Args>(args)...);
    destroy_ = [](void* p) { static_cast<T*>(p)->~T(); };
    return *held;
  }
  void reset() {
    if (destroy_) destroy_(bytes_);
    destroy_ = nullptr;
  }

 private:
  alignas(std::max_align_t) unsigned char bytes_[kBytes];
  void (*destroy_)(void*) = nullptr;
};

}  // namespace lamina
