#include "gl/functions.hpp"

#include "core/error.hpp"

namespace terrabake::gl {

Functions::Functions(const Context& context) {
#define TERRABAKE_GL_LOAD(type, name)                                                         \
  name = reinterpret_cast<type>(context.procAddress("gl" #name));                              \
  if (!name) throw InputError("gl: " + context.apiName() + " does not provide gl" #name);
  TERRABAKE_GL_FUNCTIONS(TERRABAKE_GL_LOAD)
#undef TERRABAKE_GL_LOAD
}

}  // namespace terrabake::gl
