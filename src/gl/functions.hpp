#pragma once
// The GL entry points the baker uses, loaded through the context's
// GetProcAddress. Calling gl* symbols directly would bind to whichever GL
// library the dynamic linker saw first (see ARCHITECTURE.md).
#include <GL/glcorearb.h>

#include "gl/context.hpp"

namespace terrabake::gl {

#define TERRABAKE_GL_FUNCTIONS(X)                                   \
  X(PFNGLGETSTRINGPROC, GetString)                                  \
  X(PFNGLGETERRORPROC, GetError)                                    \
  X(PFNGLVIEWPORTPROC, Viewport)                                    \
  X(PFNGLCLEARCOLORPROC, ClearColor)                                \
  X(PFNGLCLEARPROC, Clear)                                          \
  X(PFNGLDISABLEPROC, Disable)                                      \
  X(PFNGLFLUSHPROC, Flush)                                          \
  X(PFNGLFENCESYNCPROC, FenceSync)                                  \
  X(PFNGLCLIENTWAITSYNCPROC, ClientWaitSync)                        \
  X(PFNGLDELETESYNCPROC, DeleteSync)                                \
  X(PFNGLMAPBUFFERRANGEPROC, MapBufferRange)                        \
  X(PFNGLUNMAPBUFFERPROC, UnmapBuffer)                              \
  X(PFNGLPIXELSTOREIPROC, PixelStorei)                              \
  X(PFNGLREADPIXELSPROC, ReadPixels)                                \
  X(PFNGLGENFRAMEBUFFERSPROC, GenFramebuffers)                      \
  X(PFNGLDELETEFRAMEBUFFERSPROC, DeleteFramebuffers)                \
  X(PFNGLBINDFRAMEBUFFERPROC, BindFramebuffer)                      \
  X(PFNGLFRAMEBUFFERTEXTURE2DPROC, FramebufferTexture2D)            \
  X(PFNGLCHECKFRAMEBUFFERSTATUSPROC, CheckFramebufferStatus)        \
  X(PFNGLGENTEXTURESPROC, GenTextures)                              \
  X(PFNGLDELETETEXTURESPROC, DeleteTextures)                        \
  X(PFNGLBINDTEXTUREPROC, BindTexture)                              \
  X(PFNGLACTIVETEXTUREPROC, ActiveTexture)                          \
  X(PFNGLTEXIMAGE2DPROC, TexImage2D)                                \
  X(PFNGLTEXPARAMETERIPROC, TexParameteri)                          \
  X(PFNGLCREATESHADERPROC, CreateShader)                            \
  X(PFNGLSHADERSOURCEPROC, ShaderSource)                            \
  X(PFNGLCOMPILESHADERPROC, CompileShader)                          \
  X(PFNGLGETSHADERIVPROC, GetShaderiv)                              \
  X(PFNGLGETSHADERINFOLOGPROC, GetShaderInfoLog)                    \
  X(PFNGLDELETESHADERPROC, DeleteShader)                            \
  X(PFNGLCREATEPROGRAMPROC, CreateProgram)                          \
  X(PFNGLATTACHSHADERPROC, AttachShader)                            \
  X(PFNGLLINKPROGRAMPROC, LinkProgram)                              \
  X(PFNGLGETPROGRAMIVPROC, GetProgramiv)                            \
  X(PFNGLGETPROGRAMINFOLOGPROC, GetProgramInfoLog)                  \
  X(PFNGLDELETEPROGRAMPROC, DeleteProgram)                          \
  X(PFNGLUSEPROGRAMPROC, UseProgram)                                \
  X(PFNGLGETUNIFORMLOCATIONPROC, GetUniformLocation)                \
  X(PFNGLUNIFORM1IPROC, Uniform1i)                                  \
  X(PFNGLUNIFORM2IPROC, Uniform2i)                                  \
  X(PFNGLGENVERTEXARRAYSPROC, GenVertexArrays)                      \
  X(PFNGLDELETEVERTEXARRAYSPROC, DeleteVertexArrays)                \
  X(PFNGLBINDVERTEXARRAYPROC, BindVertexArray)                      \
  X(PFNGLGENBUFFERSPROC, GenBuffers)                                \
  X(PFNGLDELETEBUFFERSPROC, DeleteBuffers)                          \
  X(PFNGLBINDBUFFERPROC, BindBuffer)                                \
  X(PFNGLBUFFERDATAPROC, BufferData)                                \
  X(PFNGLBUFFERSUBDATAPROC, BufferSubData)                          \
  X(PFNGLVERTEXATTRIBPOINTERPROC, VertexAttribPointer)              \
  X(PFNGLENABLEVERTEXATTRIBARRAYPROC, EnableVertexAttribArray)      \
  X(PFNGLDRAWARRAYSPROC, DrawArrays)                                \
  X(PFNGLDRAWELEMENTSPROC, DrawElements)

struct Functions {
#define TERRABAKE_GL_DECLARE(type, name) type name = nullptr;
  TERRABAKE_GL_FUNCTIONS(TERRABAKE_GL_DECLARE)
#undef TERRABAKE_GL_DECLARE

  // Loads every entry point; throws InputError naming the first one missing.
  explicit Functions(const Context& context);
};

}  // namespace terrabake::gl
