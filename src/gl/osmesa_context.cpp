#include <GL/osmesa.h>

#include <cstdlib>
#include <string_view>
#include <vector>

#include "core/error.hpp"
#include "gl/context.hpp"

namespace terrabake::gl {
namespace {

// OSMesa renders with Mesa's software rasterisers only, and Debian 12's
// (Mesa 22.3) crashes in OSMesaCreateContextAttribs, rather than failing,
// when GALLIUM_DRIVER names any other driver ("zink", "swr", a typo): such
// a name is refused before Mesa sees it.
void checkGalliumDriver() {
  const char* driver = std::getenv("GALLIUM_DRIVER");
  if (!driver || !*driver) return;
  const std::string_view name = driver;
  if (name == "llvmpipe" || name == "softpipe") return;
  throw InputError("gl: OSMesa renders with llvmpipe or softpipe, not GALLIUM_DRIVER=\"" + shortened(driver) +
                   "\"; unset it or set one of those");
}

class OsMesaContext : public Context {
 public:
  OsMesaContext() {
    checkGalliumDriver();
    const int attribs[] = {OSMESA_FORMAT, OSMESA_RGBA,
                           OSMESA_DEPTH_BITS, 0,
                           OSMESA_PROFILE, OSMESA_COMPAT_PROFILE,
                           OSMESA_CONTEXT_MAJOR_VERSION, 3,
                           OSMESA_CONTEXT_MINOR_VERSION, 3,
                           0};
    m_context = OSMesaCreateContextAttribs(attribs, nullptr);
    if (!m_context) {
      throw InputError("gl: OSMesa could not create an OpenGL 3.3 compatibility context" + mesaSettingsNote());
    }
  }
  ~OsMesaContext() override { OSMesaDestroyContext(m_context); }

  void makeCurrent() override {
    // OSMesa needs a real buffer bound even though all drawing goes to FBOs.
    if (!OSMesaMakeCurrent(m_context, m_buffer.data(), GL_UNSIGNED_BYTE, 1, 1)) {
      throw InputError("gl: OSMesaMakeCurrent failed");
    }
  }
  void* procAddress(const char* name) const override {
    return reinterpret_cast<void*>(OSMesaGetProcAddress(name));
  }
  std::string apiName() const override { return "OSMesa"; }

 private:
  OSMesaContext m_context = nullptr;
  std::vector<unsigned char> m_buffer = std::vector<unsigned char>(4);
};

}  // namespace

std::unique_ptr<Context> createOsMesaContext() { return std::make_unique<OsMesaContext>(); }

}  // namespace terrabake::gl
