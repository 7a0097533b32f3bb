#include <array>
#include <cstdlib>
#include <string>

#include "core/error.hpp"
#include "gl/context.hpp"

namespace terrabake::gl {

std::string mesaSettingsNote() {
  // The variables by which Mesa and the EGL loader choose a driver or a GL
  // version; a context that cannot be made under one of them is most
  // likely made impossible by it.
  static constexpr std::array kNames = {"GALLIUM_DRIVER",
                                        "MESA_GL_VERSION_OVERRIDE",
                                        "MESA_LOADER_DRIVER_OVERRIDE",
                                        "LIBGL_ALWAYS_SOFTWARE",
                                        "EGL_PLATFORM",
                                        "__EGL_VENDOR_LIBRARY_FILENAMES",
                                        "__EGL_VENDOR_LIBRARY_DIRS"};
  std::string set;
  for (const char* name : kNames) {
    const char* value = std::getenv(name);
    if (!value || !*value) continue;
    set += (set.empty() ? "" : ", ") + std::string(name) + "=\"" + shortened(value) + "\"";
  }
  return set.empty() ? "" : " with " + set + " set";
}

}  // namespace terrabake::gl
