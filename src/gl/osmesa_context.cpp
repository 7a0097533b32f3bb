// OSMesa is loaded at run time (dlopen), as EGL is: a job baking on the CPU
// then starts without loading Mesa and LLVM (about 30 ms, docs/performance.md,
// "Start-up"), and the binary runs where OSMesa is absent.
#include <GL/osmesa.h>
#include <dlfcn.h>

#include <cstdlib>
#include <mutex>
#include <string_view>
#include <type_traits>
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

struct OsMesaApi {
  decltype(&OSMesaCreateContextAttribs) createContextAttribs = nullptr;
  decltype(&OSMesaDestroyContext) destroyContext = nullptr;
  decltype(&OSMesaMakeCurrent) makeCurrent = nullptr;
  decltype(&OSMesaGetProcAddress) getProcAddress = nullptr;
  bool loaded = false;
};

// Mesa's libraries resolve their symbols among their own dependencies first
// (RTLD_DEEPBIND), not along the executable's hundred and more: a load then
// takes 16-17 ms instead of 28-30 ms. AddressSanitizer refuses that flag, as
// it would let the library bypass its allocator.
#if defined(__SANITIZE_ADDRESS__)
constexpr int kDeepBind = 0;
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
constexpr int kDeepBind = 0;
#else
constexpr int kDeepBind = RTLD_DEEPBIND;
#endif
#else
constexpr int kDeepBind = RTLD_DEEPBIND;
#endif

// Loaded once per process; `loaded` false when OSMesa is missing or incomplete.
const OsMesaApi& osMesaApi() {
  static OsMesaApi api;
  static std::once_flag once;
  std::call_once(once, [] {
    void* lib = dlopen("libOSMesa.so.8", RTLD_NOW | RTLD_LOCAL | kDeepBind);
    if (!lib) return;
    auto load = [lib](auto& fn, const char* name) {
      fn = reinterpret_cast<std::remove_reference_t<decltype(fn)>>(dlsym(lib, name));
    };
    load(api.createContextAttribs, "OSMesaCreateContextAttribs");
    load(api.destroyContext, "OSMesaDestroyContext");
    load(api.makeCurrent, "OSMesaMakeCurrent");
    load(api.getProcAddress, "OSMesaGetProcAddress");
    api.loaded = api.createContextAttribs && api.destroyContext && api.makeCurrent && api.getProcAddress;
  });
  return api;
}

class OsMesaContext : public Context {
 public:
  OsMesaContext() : m_api(osMesaApi()) {
    if (!m_api.loaded) throw InputError("gl: OSMesa is not available (libOSMesa.so.8 not found or incomplete)");
    checkGalliumDriver();
    const int attribs[] = {OSMESA_FORMAT, OSMESA_RGBA,
                           OSMESA_DEPTH_BITS, 0,
                           OSMESA_PROFILE, OSMESA_COMPAT_PROFILE,
                           OSMESA_CONTEXT_MAJOR_VERSION, 3,
                           OSMESA_CONTEXT_MINOR_VERSION, 3,
                           0};
    m_context = m_api.createContextAttribs(attribs, nullptr);
    if (!m_context) {
      throw InputError("gl: OSMesa could not create an OpenGL 3.3 compatibility context" + mesaSettingsNote());
    }
  }
  ~OsMesaContext() override { m_api.destroyContext(m_context); }

  void makeCurrent() override {
    // OSMesa needs a real buffer bound even though all drawing goes to FBOs.
    if (!m_api.makeCurrent(m_context, m_buffer.data(), GL_UNSIGNED_BYTE, 1, 1)) {
      throw InputError("gl: OSMesaMakeCurrent failed");
    }
  }
  void* procAddress(const char* name) const override {
    return reinterpret_cast<void*>(m_api.getProcAddress(name));
  }
  std::string apiName() const override { return "OSMesa"; }

 private:
  const OsMesaApi& m_api;
  OSMesaContext m_context = nullptr;
  std::vector<unsigned char> m_buffer = std::vector<unsigned char>(4);
};

}  // namespace

std::unique_ptr<Context> createOsMesaContext() { return std::make_unique<OsMesaContext>(); }

}  // namespace terrabake::gl
