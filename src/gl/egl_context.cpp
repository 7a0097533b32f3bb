// EGL is loaded at run time (dlopen) so that the binary links no EGL or GL
// library next to OSMesa's own gl* symbols, and still runs where EGL is absent.
#include <EGL/egl.h>
#include <EGL/eglext.h>
#include <dlfcn.h>

#include <cstring>
#include <mutex>
#include <string>
#include <vector>

#include "core/error.hpp"
#include "gl/context.hpp"

namespace terrabake::gl {
namespace {

struct EglApi {
  PFNEGLGETPROCADDRESSPROC getProcAddress = nullptr;
  PFNEGLINITIALIZEPROC initialize = nullptr;
  PFNEGLBINDAPIPROC bindApi = nullptr;
  PFNEGLCHOOSECONFIGPROC chooseConfig = nullptr;
  PFNEGLCREATECONTEXTPROC createContext = nullptr;
  PFNEGLDESTROYCONTEXTPROC destroyContext = nullptr;
  PFNEGLMAKECURRENTPROC makeCurrent = nullptr;
  PFNEGLGETERRORPROC getError = nullptr;
  PFNEGLQUERYDEVICESEXTPROC queryDevices = nullptr;
  PFNEGLQUERYDEVICESTRINGEXTPROC queryDeviceString = nullptr;
  PFNEGLGETPLATFORMDISPLAYEXTPROC getPlatformDisplay = nullptr;
  bool loaded = false;
};

// Loaded once per process; nullptr members mean EGL or an extension is missing.
const EglApi& eglApi() {
  static EglApi api;
  static std::once_flag once;
  std::call_once(once, [] {
    void* lib = dlopen("libEGL.so.1", RTLD_NOW | RTLD_LOCAL);
    if (!lib) return;
    api.getProcAddress = reinterpret_cast<PFNEGLGETPROCADDRESSPROC>(dlsym(lib, "eglGetProcAddress"));
    if (!api.getProcAddress) return;
    auto load = [](auto& fn, const char* name) {
      fn = reinterpret_cast<std::remove_reference_t<decltype(fn)>>(api.getProcAddress(name));
    };
    load(api.initialize, "eglInitialize");
    load(api.bindApi, "eglBindAPI");
    load(api.chooseConfig, "eglChooseConfig");
    load(api.createContext, "eglCreateContext");
    load(api.destroyContext, "eglDestroyContext");
    load(api.makeCurrent, "eglMakeCurrent");
    load(api.getError, "eglGetError");
    load(api.queryDevices, "eglQueryDevicesEXT");
    load(api.queryDeviceString, "eglQueryDeviceStringEXT");
    load(api.getPlatformDisplay, "eglGetPlatformDisplayEXT");
    api.loaded = api.initialize && api.bindApi && api.chooseConfig && api.createContext &&
                 api.destroyContext && api.makeCurrent && api.getError && api.getPlatformDisplay;
  });
  return api;
}

// Hardware devices: those EGL lists that are not Mesa's software device.
std::vector<EGLDeviceEXT> hardwareDevices(const EglApi& api) {
  std::vector<EGLDeviceEXT> result;
  if (!api.loaded || !api.queryDevices || !api.queryDeviceString) return result;
  EGLint count = 0;
  if (!api.queryDevices(0, nullptr, &count) || count <= 0) return result;
  std::vector<EGLDeviceEXT> devices(count);
  if (!api.queryDevices(count, devices.data(), &count)) return result;
  for (int i = 0; i < count; ++i) {
    const char* extensions = api.queryDeviceString(devices[i], EGL_EXTENSIONS);
    if (extensions && std::strstr(extensions, "EGL_MESA_device_software")) continue;
    result.push_back(devices[i]);
  }
  return result;
}

// EGL's name of an error code (EGL 1.5, table 3.1), or its number.
std::string eglErrorName(EGLint code) {
  switch (code) {
    case EGL_NOT_INITIALIZED: return "EGL_NOT_INITIALIZED";
    case EGL_BAD_ACCESS: return "EGL_BAD_ACCESS";
    case EGL_BAD_ALLOC: return "EGL_BAD_ALLOC";
    case EGL_BAD_ATTRIBUTE: return "EGL_BAD_ATTRIBUTE";
    case EGL_BAD_CONFIG: return "EGL_BAD_CONFIG";
    case EGL_BAD_CONTEXT: return "EGL_BAD_CONTEXT";
    case EGL_BAD_CURRENT_SURFACE: return "EGL_BAD_CURRENT_SURFACE";
    case EGL_BAD_DISPLAY: return "EGL_BAD_DISPLAY";
    case EGL_BAD_MATCH: return "EGL_BAD_MATCH";
    case EGL_BAD_NATIVE_PIXMAP: return "EGL_BAD_NATIVE_PIXMAP";
    case EGL_BAD_NATIVE_WINDOW: return "EGL_BAD_NATIVE_WINDOW";
    case EGL_BAD_PARAMETER: return "EGL_BAD_PARAMETER";
    case EGL_BAD_SURFACE: return "EGL_BAD_SURFACE";
    case EGL_CONTEXT_LOST: return "EGL_CONTEXT_LOST";
  }
  char number[16];
  std::snprintf(number, sizeof number, "error 0x%04x", unsigned(code));
  return number;
}

[[noreturn]] void fail(const EglApi& api, const std::string& what) {
  const EGLint code = api.getError ? api.getError() : EGL_SUCCESS;
  throw InputError("gl: EGL " + what + " failed (" + eglErrorName(code) + ")" + mesaSettingsNote());
}

class EglContext : public Context {
 public:
  explicit EglContext(EglPlatform platform) : m_api(eglApi()) {
    if (!m_api.loaded) throw InputError("gl: EGL is not available (libEGL.so.1 not found or incomplete)");
    if (platform == EglPlatform::kDevice) {
      const auto devices = hardwareDevices(m_api);
      if (devices.empty()) throw InputError("gl: EGL found no hardware GPU device");
      m_display = m_api.getPlatformDisplay(EGL_PLATFORM_DEVICE_EXT, devices.front(), nullptr);
      m_name = "EGL (device)";
    } else {
      m_display = m_api.getPlatformDisplay(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, nullptr);
      m_name = "EGL (surfaceless)";
    }
    if (m_display == EGL_NO_DISPLAY) fail(m_api, "display for " + m_name);
    // Initialising a display again is harmless; it is never terminated
    // because other threads may hold contexts on the same display.
    if (!m_api.initialize(m_display, nullptr, nullptr)) fail(m_api, "initialise");
    if (!m_api.bindApi(EGL_OPENGL_API)) fail(m_api, "bind OpenGL API");

    const EGLint config_attribs[] = {EGL_RENDERABLE_TYPE, EGL_OPENGL_BIT, EGL_NONE};
    EGLConfig config = nullptr;
    EGLint config_count = 0;
    if (!m_api.chooseConfig(m_display, config_attribs, &config, 1, &config_count) || config_count < 1) {
      config = nullptr;  // EGL_KHR_no_config_context: drawing goes to FBOs only
    }
    const EGLint context_attribs[] = {EGL_CONTEXT_MAJOR_VERSION, 3,
                                      EGL_CONTEXT_MINOR_VERSION, 3,
                                      EGL_CONTEXT_OPENGL_PROFILE_MASK, EGL_CONTEXT_OPENGL_COMPATIBILITY_PROFILE_BIT,
                                      EGL_NONE};
    m_context = m_api.createContext(m_display, config, EGL_NO_CONTEXT, context_attribs);
    if (m_context == EGL_NO_CONTEXT) fail(m_api, "create an OpenGL 3.3 compatibility context");
  }

  ~EglContext() override {
    m_api.makeCurrent(m_display, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
    m_api.destroyContext(m_display, m_context);
  }

  void makeCurrent() override {
    if (!m_api.makeCurrent(m_display, EGL_NO_SURFACE, EGL_NO_SURFACE, m_context)) fail(m_api, "make current");
  }
  void* procAddress(const char* name) const override {
    return reinterpret_cast<void*>(m_api.getProcAddress(name));
  }
  std::string apiName() const override { return m_name; }

 private:
  const EglApi& m_api;
  EGLDisplay m_display = EGL_NO_DISPLAY;
  EGLContext m_context = EGL_NO_CONTEXT;
  std::string m_name;
};

}  // namespace

std::unique_ptr<Context> createEglContext(EglPlatform platform) {
  return std::make_unique<EglContext>(platform);
}

bool hasHardwareEglDevice() { return !hardwareDevices(eglApi()).empty(); }

}  // namespace terrabake::gl
