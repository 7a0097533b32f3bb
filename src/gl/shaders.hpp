#pragma once
// GLSL sources from shaders/, compiled into the binary at build time.
namespace terrabake::gl::shaders {
extern const char* const kBakeVertex;
extern const char* const kBakeFragment;
extern const char* const kTangentSpaceVertex;
extern const char* const kTangentSpaceFragment;
extern const char* const kOctahedron;  // functions both stages of both passes link
}  // namespace terrabake::gl::shaders
