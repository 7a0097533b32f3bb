#include "gl/gl_baker.hpp"

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

GLuint linkProgram(const Functions& gl) {
  const GLuint vertex = compileShader(gl, GL_VERTEX_SHADER, shaders::kBakeVertex);
  const GLuint fragment = compileShader(gl, GL_FRAGMENT_SHADER, shaders::kBakeFragment);
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
  GLuint program = 0, vao = 0, vertex_buffer = 0, index_buffer = 0;
  GLuint frame_texture = 0, target_texture = 0, framebuffer = 0;
  GLint grid_location = -1, tile_size_location = -1, low_poly_location = -1;
  int target_size = 0;         // size of target_texture, 0 = none yet
  int index_cols = 0, index_rows = 0;  // grid the index buffer was built for
  GLsizei index_count = 0;

  explicit Impl(std::unique_ptr<Context> ctx) : context(std::move(ctx)), gl(makeCurrent(*context)) {
    const auto* version = reinterpret_cast<const char*>(gl.GetString(GL_VERSION));
    const auto* renderer = reinterpret_cast<const char*>(gl.GetString(GL_RENDERER));
    if (!version || !renderer) throw InputError("gl: " + context->apiName() + " context is not usable");
    description = std::string("OpenGL ") + version + " (" + renderer + ") via " + context->apiName();

    program = linkProgram(gl);
    grid_location = gl.GetUniformLocation(program, "u_grid");
    tile_size_location = gl.GetUniformLocation(program, "u_tile_size");
    low_poly_location = gl.GetUniformLocation(program, "u_low_poly");
    gl.GenVertexArrays(1, &vao);
    gl.GenBuffers(1, &vertex_buffer);
    gl.GenBuffers(1, &index_buffer);
    gl.GenTextures(1, &frame_texture);
    gl.GenTextures(1, &target_texture);
    gl.GenFramebuffers(1, &framebuffer);
  }

  ~Impl() {
    gl.DeleteFramebuffers(1, &framebuffer);
    gl.DeleteTextures(1, &target_texture);
    gl.DeleteTextures(1, &frame_texture);
    gl.DeleteBuffers(1, &index_buffer);
    gl.DeleteBuffers(1, &vertex_buffer);
    gl.DeleteVertexArrays(1, &vao);
    gl.DeleteProgram(program);
  }

  void checkError(const char* where) {
    const GLenum error = gl.GetError();
    if (error != GL_NO_ERROR) {
      char code[16];
      std::snprintf(code, sizeof code, "0x%04x", error);
      throw InputError(std::string("gl: ") + where + " failed (GL error " + code + ")");
    }
  }

  // A float target keeps full precision; quantisation happens once, on the
  // CPU, with the same code for every backend.
  void prepareTarget(int size) {
    if (size == target_size) return;
    gl.BindTexture(GL_TEXTURE_2D, target_texture);
    gl.TexImage2D(GL_TEXTURE_2D, 0, GL_RGBA32F, size, size, 0, GL_RGBA, GL_FLOAT, nullptr);
    gl.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
    gl.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
    gl.BindFramebuffer(GL_FRAMEBUFFER, framebuffer);
    gl.FramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, target_texture, 0);
    if (gl.CheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE) {
      throw InputError("gl: RGBA32F framebuffer of " + std::to_string(size) + " texels is not supported");
    }
    target_size = size;
  }

  void uploadHighRes(const mesh::HighResMesh& high) {
    std::vector<float> vertices;
    vertices.reserve(high.uv.size() * 5);
    for (std::size_t i = 0; i < high.uv.size(); ++i) {
      vertices.insert(vertices.end(), {high.uv[i].x, high.uv[i].y, high.normal[i].x, high.normal[i].y,
                                       high.normal[i].z});
    }
    gl.BindVertexArray(vao);
    gl.BindBuffer(GL_ARRAY_BUFFER, vertex_buffer);
    gl.BufferData(GL_ARRAY_BUFFER, GLsizeiptr(vertices.size() * sizeof(float)), vertices.data(), GL_STREAM_DRAW);
    gl.VertexAttribPointer(0, 2, GL_FLOAT, GL_FALSE, 5 * sizeof(float), nullptr);
    gl.VertexAttribPointer(1, 3, GL_FLOAT, GL_FALSE, 5 * sizeof(float),
                           reinterpret_cast<const void*>(2 * sizeof(float)));
    gl.EnableVertexAttribArray(0);
    gl.EnableVertexAttribArray(1);
    gl.BindBuffer(GL_ELEMENT_ARRAY_BUFFER, index_buffer);
    if (high.cols != index_cols || high.rows != index_rows) {
      const auto indices = mesh::gridIndices(high.cols, high.rows);
      gl.BufferData(GL_ELEMENT_ARRAY_BUFFER, GLsizeiptr(indices.size() * sizeof(std::uint32_t)), indices.data(),
                    GL_STATIC_DRAW);
      index_cols = high.cols;
      index_rows = high.rows;
      index_count = GLsizei(indices.size());
    }
  }

  void uploadLowPolyFrames(const mesh::GridMesh& low) {
    const int g = low.grid;
    std::vector<float> texels(std::size_t(g) * 2 * g * 4);
    for (int k = 0; k < g * g; ++k) {
      const glm::vec3& n = low.normal[k];
      const glm::vec4& t = low.tangent[k];
      const std::size_t normal_at = std::size_t(k) * 4, tangent_at = (std::size_t(g) * g + k) * 4;
      texels[normal_at + 0] = n.x, texels[normal_at + 1] = n.y, texels[normal_at + 2] = n.z;
      texels[tangent_at + 0] = t.x, texels[tangent_at + 1] = t.y, texels[tangent_at + 2] = t.z;
      texels[tangent_at + 3] = t.w;
    }
    gl.ActiveTexture(GL_TEXTURE0);
    gl.BindTexture(GL_TEXTURE_2D, frame_texture);
    gl.PixelStorei(GL_UNPACK_ALIGNMENT, 4);
    gl.TexImage2D(GL_TEXTURE_2D, 0, GL_RGBA32F, g, 2 * g, 0, GL_RGBA, GL_FLOAT, texels.data());
    gl.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
    gl.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
  }
};

GlBaker::GlBaker(std::unique_ptr<Context> context) : m_impl(std::make_unique<Impl>(std::move(context))) {}
GlBaker::~GlBaker() = default;

std::string GlBaker::description() const { return m_impl->description; }

bake::NormalMap GlBaker::bake(const mesh::HighResMesh& high, const mesh::GridMesh& low, int size) {
  Impl& s = *m_impl;
  const Functions& gl = s.gl;
  s.prepareTarget(size);
  s.uploadHighRes(high);
  s.uploadLowPolyFrames(low);

  gl.BindFramebuffer(GL_FRAMEBUFFER, s.framebuffer);
  gl.Viewport(0, 0, size, size);
  gl.Disable(GL_DEPTH_TEST);
  gl.Disable(GL_CULL_FACE);  // UV-space triangles may face either way
  gl.ClearColor(0, 0, 0, 0);
  gl.Clear(GL_COLOR_BUFFER_BIT);
  gl.UseProgram(s.program);
  gl.Uniform1i(s.grid_location, low.grid);
  gl.Uniform1f(s.tile_size_location, float(size));
  gl.Uniform1i(s.low_poly_location, 0);
  gl.BindVertexArray(s.vao);
  gl.DrawElements(GL_TRIANGLES, s.index_count, GL_UNSIGNED_INT, nullptr);

  std::vector<float> rgba(std::size_t(size) * size * 4);
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
