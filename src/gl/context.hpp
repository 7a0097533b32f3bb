#pragma once
// An OpenGL 3.3+ compatibility-profile context that renders offscreen.
// Backends differ only in how the context is made; everything draws into
// framebuffer objects. Compatibility, not core: there points are plain points,
// not point sprites, and llvmpipe bins a plain point as a rectangle instead of
// a four-edged polygon. The first pass draws a point per texel (see
// gl_baker.cpp); in a batch run on llvmpipe (463 tiles, 2 workers) the bake
// stage took 6.7-6.9 ms a tile against 11.4-11.8 ms in a core context, with
// the same bytes. The shaders are GLSL 3.30 core and use nothing else of the
// profile.
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

// " with GALLIUM_DRIVER=\"zink\" set" for the Mesa and EGL loader variables
// the environment sets, "" for none: added to an error that a context could
// not be made, which Mesa's own codes leave unexplained.
std::string mesaSettingsNote();

enum class EglPlatform {
  kDevice,       // a hardware GPU through EGL_EXT_platform_device
  kSurfaceless,  // Mesa's surfaceless platform (llvmpipe without a GPU)
};
std::unique_ptr<Context> createEglContext(EglPlatform platform);

// True when EGL can reach a GPU that is not a software renderer.
bool hasHardwareEglDevice();

}  // namespace terrabake::gl
