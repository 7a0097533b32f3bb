#include "gl/gl_baker.hpp"

#include <cstdio>
#include <initializer_list>
#include <utility>
#include <vector>

#include "core/error.hpp"
#include "gl/functions.hpp"
#include "gl/shaders.hpp"

namespace terrabake::gl {
namespace {

GLuint compileShader(const Functions& gl, GLenum type, const char* source) {
  const GLuint shader = gl.CreateShader(type);
  gl.ShaderSource(shader, 1, &source, nullptr);
  gl.CompileShader(shader);
  GLint ok = GL_FALSE;
  gl.GetShaderiv(shader, GL_COMPILE_STATUS, &ok);
  if (!ok) {
    char log[2048] = {};
    gl.GetShaderInfoLog(shader, sizeof log, nullptr, log);
    gl.DeleteShader(shader);
    throw InputError(std::string("gl: shader does not compile: ") + oneLine(log));
  }
  return shader;
}

GLuint linkProgram(const Functions& gl, const char* vertex_source, const char* fragment_source) {
  const GLuint vertex = compileShader(gl, GL_VERTEX_SHADER, vertex_source);
  const GLuint fragment = compileShader(gl, GL_FRAGMENT_SHADER, fragment_source);
  const GLuint program = gl.CreateProgram();
  gl.AttachShader(program, vertex);
  gl.AttachShader(program, fragment);
  gl.LinkProgram(program);
  gl.DeleteShader(vertex);
  gl.DeleteShader(fragment);
  GLint ok = GL_FALSE;
  gl.GetProgramiv(program, GL_LINK_STATUS, &ok);
  if (!ok) {
    char log[2048] = {};
    gl.GetProgramInfoLog(program, sizeof log, nullptr, log);
    gl.DeleteProgram(program);
    throw InputError(std::string("gl: shaders do not link: ") + oneLine(log));
  }
  return program;
}

// The low-poly frame, interpolated per texel by the first pass: normal,
// tangent and bitangent, one float texture each.
constexpr int kFrameParts = 3;
// Texture units of the third pass: the high-res normals, then the frame.
constexpr int kHighNormalUnit = 0;
constexpr int kFirstFrameUnit = 1;

// A buffer object whose storage is made again only when the data outgrows
// it: re-specifying storage for every tile makes a software renderer map and
// fault in fresh pages each time.
struct StreamBuffer {
  GLuint name = 0;
  GLsizeiptr capacity = 0;  // bytes

  void upload(const Functions& gl, GLenum target, GLsizeiptr bytes, const void* data) {
    gl.BindBuffer(target, name);
    if (bytes > capacity) {
      gl.BufferData(target, bytes, data, GL_STREAM_DRAW);
      capacity = bytes;
    } else {
      gl.BufferSubData(target, 0, bytes, data);
    }
  }
};

// Entry points can only be loaded once the context is current.
const Context& makeCurrent(Context& context) {
  context.makeCurrent();
  return context;
}

}  // namespace

struct GlBaker::Impl {
  std::unique_ptr<Context> context;
  Functions gl;
  std::string description;
  GLuint frame_program = 0, bake_program = 0, tangent_space_program = 0;
  GLuint high_vao = 0, high_indices = 0;
  GLuint low_vao = 0;
  GLuint no_vertices_vao = 0;  // the third pass makes its triangle from gl_VertexID
  StreamBuffer high_vertices, low_vertices, low_indices;
  // Kept from tile to tile, for the same reason as the buffers.
  std::vector<float> interleaved, read_back;
  GLuint frame_textures[kFrameParts] = {}, frame_framebuffer = 0;
  GLuint high_normal_texture = 0, high_normal_framebuffer = 0;
  GLuint target_texture = 0, target_framebuffer = 0;
  int target_size = 0;                 // size of the textures, 0 = none yet
  int index_cols = 0, index_rows = 0;  // grid the high-res index buffer was built for
  GLsizei high_index_count = 0, low_index_count = 0;

  explicit Impl(std::unique_ptr<Context> ctx) : context(std::move(ctx)), gl(makeCurrent(*context)) {
    const auto* version = reinterpret_cast<const char*>(gl.GetString(GL_VERSION));
    const auto* renderer = reinterpret_cast<const char*>(gl.GetString(GL_RENDERER));
    if (!version || !renderer) throw InputError("gl: " + context->apiName() + " context is not usable");
    description = std::string("OpenGL ") + version + " (" + renderer + ") via " + context->apiName();

    frame_program = linkProgram(gl, shaders::kFrameVertex, shaders::kFrameFragment);
    bake_program = linkProgram(gl, shaders::kBakeVertex, shaders::kBakeFragment);
    tangent_space_program = linkProgram(gl, shaders::kTangentSpaceVertex, shaders::kTangentSpaceFragment);
    gl.UseProgram(tangent_space_program);
    gl.Uniform1i(gl.GetUniformLocation(tangent_space_program, "u_high_normal"), kHighNormalUnit);
    const char* frame_samplers[kFrameParts] = {"u_frame_normal", "u_frame_tangent", "u_frame_bitangent"};
    for (int k = 0; k < kFrameParts; ++k) {
      gl.Uniform1i(gl.GetUniformLocation(tangent_space_program, frame_samplers[k]), kFirstFrameUnit + k);
    }
    gl.GenVertexArrays(1, &high_vao);
    gl.GenVertexArrays(1, &low_vao);
    gl.GenVertexArrays(1, &no_vertices_vao);
    gl.GenBuffers(1, &high_vertices.name);
    gl.GenBuffers(1, &high_indices);
    gl.GenBuffers(1, &low_vertices.name);
    gl.GenBuffers(1, &low_indices.name);
    gl.GenTextures(kFrameParts, frame_textures);
    gl.GenTextures(1, &high_normal_texture);
    gl.GenTextures(1, &target_texture);
    gl.GenFramebuffers(1, &frame_framebuffer);
    gl.GenFramebuffers(1, &high_normal_framebuffer);
    gl.GenFramebuffers(1, &target_framebuffer);
  }

  ~Impl() {
    gl.DeleteFramebuffers(1, &target_framebuffer);
    gl.DeleteFramebuffers(1, &high_normal_framebuffer);
    gl.DeleteFramebuffers(1, &frame_framebuffer);
    gl.DeleteTextures(1, &target_texture);
    gl.DeleteTextures(1, &high_normal_texture);
    gl.DeleteTextures(kFrameParts, frame_textures);
    gl.DeleteBuffers(1, &low_indices.name);
    gl.DeleteBuffers(1, &low_vertices.name);
    gl.DeleteBuffers(1, &high_indices);
    gl.DeleteBuffers(1, &high_vertices.name);
    gl.DeleteVertexArrays(1, &no_vertices_vao);
    gl.DeleteVertexArrays(1, &low_vao);
    gl.DeleteVertexArrays(1, &high_vao);
    gl.DeleteProgram(tangent_space_program);
    gl.DeleteProgram(bake_program);
    gl.DeleteProgram(frame_program);
  }

  void checkError(const char* where) {
    const GLenum error = gl.GetError();
    if (error != GL_NO_ERROR) {
      char code[16];
      std::snprintf(code, sizeof code, "0x%04x", error);
      throw InputError(std::string("gl: ") + where + " failed (GL error " + code + ")");
    }
  }

  // Float targets keep full precision; quantisation happens once, on the
  // CPU, with the same code for every backend.
  void allocateFloatTexture(GLuint texture, int size) {
    gl.BindTexture(GL_TEXTURE_2D, texture);
    gl.TexImage2D(GL_TEXTURE_2D, 0, GL_RGBA32F, size, size, 0, GL_RGBA, GL_FLOAT, nullptr);
    gl.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
    gl.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
  }

  void checkFramebuffer(int size) {
    if (gl.CheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE) {
      throw InputError("gl: RGBA32F framebuffer of " + std::to_string(size) + " texels is not supported");
    }
  }

  void prepareTargets(int size) {
    if (size == target_size) return;
    gl.BindFramebuffer(GL_FRAMEBUFFER, frame_framebuffer);
    GLenum attachments[kFrameParts];
    for (int k = 0; k < kFrameParts; ++k) {
      allocateFloatTexture(frame_textures[k], size);
      attachments[k] = GLenum(GL_COLOR_ATTACHMENT0 + k);
      gl.FramebufferTexture2D(GL_FRAMEBUFFER, attachments[k], GL_TEXTURE_2D, frame_textures[k], 0);
    }
    gl.DrawBuffers(kFrameParts, attachments);
    checkFramebuffer(size);
    for (auto [framebuffer, texture] : {std::pair{high_normal_framebuffer, high_normal_texture},
                                        std::pair{target_framebuffer, target_texture}}) {
      gl.BindFramebuffer(GL_FRAMEBUFFER, framebuffer);
      allocateFloatTexture(texture, size);
      gl.FramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, texture, 0);
      checkFramebuffer(size);
    }
    target_size = size;
  }

  // `interleaved` as float attributes: `layout` lists each attribute's width.
  void uploadVertices(GLuint vao, StreamBuffer& buffer, std::initializer_list<int> layout) {
    gl.BindVertexArray(vao);
    buffer.upload(gl, GL_ARRAY_BUFFER, GLsizeiptr(interleaved.size() * sizeof(float)), interleaved.data());
    int stride = 0;
    for (int width : layout) stride += width;
    int offset = 0;
    GLuint location = 0;
    for (int width : layout) {
      gl.VertexAttribPointer(location, width, GL_FLOAT, GL_FALSE, GLsizei(stride * sizeof(float)),
                             reinterpret_cast<const void*>(std::size_t(offset) * sizeof(float)));
      gl.EnableVertexAttribArray(location++);
      offset += width;
    }
  }

  void uploadHighRes(const mesh::HighResMesh& high) {
    interleaved.clear();
    for (std::size_t i = 0; i < high.uv.size(); ++i) {
      interleaved.insert(interleaved.end(), {high.uv[i].x, high.uv[i].y, high.normal[i].x, high.normal[i].y,
                                             high.normal[i].z});
    }
    uploadVertices(high_vao, high_vertices, {2, 3});
    gl.BindBuffer(GL_ELEMENT_ARRAY_BUFFER, high_indices);
    if (high.cols != index_cols || high.rows != index_rows) {
      const auto indices = mesh::gridIndices(high.cols, high.rows);
      gl.BufferData(GL_ELEMENT_ARRAY_BUFFER, GLsizeiptr(indices.size() * sizeof(std::uint32_t)), indices.data(),
                    GL_STATIC_DRAW);
      index_cols = high.cols;
      index_rows = high.rows;
      high_index_count = GLsizei(indices.size());
    }
  }

  void uploadLowPoly(const mesh::TriangleMesh& low) {
    interleaved.clear();
    for (std::size_t i = 0; i < low.uv.size(); ++i) {
      const glm::vec3& n = low.normal[i];
      const glm::vec4& t = low.tangent[i];
      interleaved.insert(interleaved.end(), {low.uv[i].x, low.uv[i].y, n.x, n.y, n.z, t.x, t.y, t.z, t.w});
    }
    uploadVertices(low_vao, low_vertices, {2, 3, 4});
    low_indices.upload(gl, GL_ELEMENT_ARRAY_BUFFER, GLsizeiptr(low.indices.size() * sizeof(std::uint32_t)),
                       low.indices.data());
    low_index_count = GLsizei(low.indices.size());
  }
};

GlBaker::GlBaker(std::unique_ptr<Context> context) : m_impl(std::make_unique<Impl>(std::move(context))) {}
GlBaker::~GlBaker() = default;

std::string GlBaker::description() const { return m_impl->description; }

bake::NormalMap GlBaker::bake(const mesh::HighResMesh& high, const mesh::TriangleMesh& low, int size) {
  Impl& s = *m_impl;
  const Functions& gl = s.gl;
  s.prepareTargets(size);
  s.uploadLowPoly(low);
  s.uploadHighRes(high);
  gl.Viewport(0, 0, size, size);
  gl.Disable(GL_DEPTH_TEST);
  gl.Disable(GL_CULL_FACE);  // UV-space triangles may face either way
  gl.ClearColor(0, 0, 0, 0);

  // Pass 1: the low-poly frame at every texel.
  gl.BindFramebuffer(GL_FRAMEBUFFER, s.frame_framebuffer);
  gl.Clear(GL_COLOR_BUFFER_BIT);
  gl.UseProgram(s.frame_program);
  gl.BindVertexArray(s.low_vao);
  gl.DrawElements(GL_TRIANGLES, s.low_index_count, GL_UNSIGNED_INT, nullptr);

  // Pass 2: the high-res normal at every texel.
  gl.BindFramebuffer(GL_FRAMEBUFFER, s.high_normal_framebuffer);
  gl.Clear(GL_COLOR_BUFFER_BIT);
  gl.UseProgram(s.bake_program);
  gl.BindVertexArray(s.high_vao);
  gl.DrawElements(GL_TRIANGLES, s.high_index_count, GL_UNSIGNED_INT, nullptr);

  // Pass 3: that normal in the low-poly frame, once per texel.
  gl.BindFramebuffer(GL_FRAMEBUFFER, s.target_framebuffer);
  gl.UseProgram(s.tangent_space_program);
  gl.ActiveTexture(GLenum(GL_TEXTURE0 + kHighNormalUnit));
  gl.BindTexture(GL_TEXTURE_2D, s.high_normal_texture);
  for (int k = 0; k < kFrameParts; ++k) {
    gl.ActiveTexture(GLenum(GL_TEXTURE0 + kFirstFrameUnit + k));
    gl.BindTexture(GL_TEXTURE_2D, s.frame_textures[k]);
  }
  gl.BindVertexArray(s.no_vertices_vao);
  gl.DrawArrays(GL_TRIANGLES, 0, 3);

  std::vector<float>& rgba = s.read_back;
  rgba.resize(std::size_t(size) * size * 4);
  gl.PixelStorei(GL_PACK_ALIGNMENT, 4);
  gl.ReadPixels(0, 0, size, size, GL_RGBA, GL_FLOAT, rgba.data());
  s.checkError("bake");

  bake::NormalMap map;
  map.size = size;
  map.texels.resize(std::size_t(size) * size);
  for (std::size_t k = 0; k < map.texels.size(); ++k) {
    map.texels[k] = glm::vec3(rgba[4 * k], rgba[4 * k + 1], rgba[4 * k + 2]);
  }
  return map;
}

}  // namespace terrabake::gl
