#pragma once
// An OpenGL 3.3+ core context that renders offscreen. Backends differ only in
// how the context is made; everything draws into framebuffer objects.
#include <memory>
#include <string>

namespace terrabake::gl {

class Context {
 public:
  virtual ~Context() = default;
  // Binds the context to the calling thread.
  virtual void makeCurrent() = 0;
  virtual void* procAddress(const char* name) const = 0;
  // "OSMesa" or "EGL (device)" / "EGL (surfaceless)".
  virtual std::string apiName() const = 0;
};

// Throw InputError when the context cannot be made.
std::unique_ptr<Context> createOsMesaContext();

enum class EglPlatform {
  kDevice,       // a hardware GPU through EGL_EXT_platform_device
  kSurfaceless,  // Mesa's surfaceless platform (llvmpipe without a GPU)
};
std::unique_ptr<Context> createEglContext(EglPlatform platform);

// True when EGL can reach a GPU that is not a software renderer.
bool hasHardwareEglDevice();

}  // namespace terrabake::gl
