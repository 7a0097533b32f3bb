#include "gl/gl_baker.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <initializer_list>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "core/error.hpp"
#include "core/lanes.hpp"
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

// A program of a vertex and a fragment shader, each linked with the
// octahedron functions.
GLuint linkProgram(const Functions& gl, const char* vertex_source, const char* fragment_source) {
  const GLuint stages[] = {compileShader(gl, GL_VERTEX_SHADER, vertex_source),
                           compileShader(gl, GL_VERTEX_SHADER, shaders::kOctahedron),
                           compileShader(gl, GL_FRAGMENT_SHADER, fragment_source),
                           compileShader(gl, GL_FRAGMENT_SHADER, shaders::kOctahedron)};
  const GLuint program = gl.CreateProgram();
  for (GLuint shader : stages) gl.AttachShader(program, shader);
  gl.LinkProgram(program);
  for (GLuint shader : stages) gl.DeleteShader(shader);
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

// Texture unit of the second pass's high-res normals.
constexpr int kHighNormalUnit = 0;

// The first pass's clear colour: tangent_space.frag's kNoNormal, outside the
// octahedron's square, where no high-res vertex writes a normal.
constexpr float kNoNormal = 2.0f;

// The first pass draws the high-res mesh's vertices as points. Each vertex
// lies on a texel centre and no other texel centre lies in the mesh's
// triangles, so what the triangles hold at the texel centres is their
// vertices' normals: points write them with half the primitives and no
// index buffer. Measured in one run on an NVIDIA H200, tiles baked a
// second by 16 threads: 5,231-5,302 with points, 4,925-5,015 with
// triangles; on llvmpipe, one thread, a 256-texel tile's bake took
// 12.0-12.4 ms against 12.7-15.1 ms. Every point lies inside the viewport:
// llvmpipe sends each batch of vertices that holds one outside through its
// slow clipping pipeline (see docs/performance.md). The vertex stage places
// each vertex by its index in the grid, so a tile uploads its normals alone:
// in a batch run on llvmpipe (463 tiles, 2 workers) the bake stage took
// 10.0-11.2 ms a tile against 11.1-11.8 ms reading a UV buffer. The
// contexts are compatibility-profile ones, where points are not sprites
// (see context.hpp).

// llvmpipe bins a whole scene of primitives before it rasterises any, and a
// point takes on the order of a hundred bytes of binned data. Where it
// rasterises on the drawing thread (LP_NUM_THREADS=0, as the workers of a
// batch run have it: see baker_factory.hpp) the first pass is flushed after
// every this many points, so each scene is still in the cache when it is
// rasterised. In a batch run (463 tiles, 2 workers) the bake stage took
// 5.2-5.8 ms a tile against 7.3-8.0 ms in one scene, with scenes of 1,024 to
// 8,192 points alike; the texels are the same. With rasterising threads of
// its own (one worker, 2 cores) it gained nothing within the machine's swing,
// and a hardware GPU draws the pass in one go: there each flush is a
// submission.
constexpr GLsizei kLlvmpipeScenePoints = 8192;

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

// How long mapResult() waits for the GPU before it gives up on a tile: a bake
// takes milliseconds, so this is a driver or device that stopped answering.
constexpr std::chrono::seconds kGpuStallLimit{60};

// Vertex data goes to GL straight from the meshes' arrays.
static_assert(sizeof(glm::vec3) == 3 * sizeof(float) && sizeof(glm::vec2) == 2 * sizeof(float));

// The inverse of octahedron.glsl's octahedronEncoded, a lane per texel;
// (0, 0, 0) where it wrote kNoNormal, a texel without a normal.
void decodeOctahedra(const glm::vec2* encoded, std::size_t count, glm::vec3* normals) {
  const Floats zero{}, one = zero + 1;
  for (std::size_t first = 0; first < count; first += kFloatLanes) {
    const std::size_t lanes = std::min(std::size_t(kFloatLanes), count - first);
    Floats ex = zero, ey = zero;
    for (std::size_t k = 0; k < lanes; ++k) ex[k] = encoded[first + k].x, ey[k] = encoded[first + k].y;
    const Floats ax = ex < zero ? -ex : ex, ay = ey < zero ? -ey : ey;
    const Floats z = one - ax - ay;
    const Floats fold = z < zero ? -z : zero;  // the lower half folds over the square's corners
    const Floats x = ex >= zero ? ex - fold : ex + fold;
    const Floats y = ey >= zero ? ey - fold : ey + fold;
    const Floats scale = ((ax > one) | (ay > one)) ? zero : one / squareRoot(x * x + y * y + z * z);
    for (std::size_t k = 0; k < lanes; ++k) normals[first + k] = {x[k] * scale[k], y[k] * scale[k], z[k] * scale[k]};
  }
}

// Entry points can only be loaded once the context is current.
const Context& makeCurrent(Context& context) {
  context.makeCurrent();
  return context;
}

}  // namespace

// What one tile in flight needs of its own: its vertices, the two passes'
// targets, and the buffer its result is read back into.
struct Slot {
  GLuint high_vao = 0, low_vao = 0;
  StreamBuffer high_normals, low_vertices, low_indices;
  GLsizei low_index_count = 0;
  GLuint high_normal_texture = 0, high_normal_framebuffer = 0;
  GLuint target_texture = 0, target_framebuffer = 0;
  GLuint read_back_buffer = 0;  // pixel pack buffer: reading back need not wait for the GPU
  int size = 0;                 // size of the textures, 0 = none yet
  GLsync done = nullptr;        // signalled when the read back has landed
  bool mapped = false;          // the read back is mapped for a caller to copy
  bool taken() const { return done || mapped; }

  // The slot's GL names by kind, made and deleted together.
  std::array<GLuint*, 2> vertexArrays() { return {&high_vao, &low_vao}; }
  std::array<GLuint*, 4> buffers() {
    return {&high_normals.name, &low_vertices.name, &low_indices.name, &read_back_buffer};
  }
  std::array<GLuint*, 2> textures() { return {&high_normal_texture, &target_texture}; }
  std::array<GLuint*, 2> framebuffers() { return {&high_normal_framebuffer, &target_framebuffer}; }
};

struct GlBaker::Impl {
  std::unique_ptr<Context> context;
  Functions gl;
  std::string description;
  GLsizei points_per_scene = 0;  // first-pass points between flushes; 0: one draw
  GLuint bake_program = 0, tangent_space_program = 0;
  GLint grid_uniform = -1;  // bake.vert's u_grid
  std::vector<Slot> slots;
  // Kept from tile to tile, for the same reason as the buffers.
  std::vector<float> interleaved;

  Impl(std::unique_ptr<Context> ctx, int in_flight)
      : context(std::move(ctx)), gl(makeCurrent(*context)), slots(std::size_t(std::max(in_flight, 1))) {
    const auto* version = reinterpret_cast<const char*>(gl.GetString(GL_VERSION));
    const auto* renderer = reinterpret_cast<const char*>(gl.GetString(GL_RENDERER));
    if (!version || !renderer) throw InputError("gl: " + context->apiName() + " context is not usable");
    description = std::string("OpenGL ") + version + " (" + renderer + ") via " + context->apiName();
    const char* rasteriser_threads = std::getenv("LP_NUM_THREADS");
    if (std::strstr(renderer, "llvmpipe") && rasteriser_threads && std::string(rasteriser_threads) == "0") {
      points_per_scene = kLlvmpipeScenePoints;
    }

    bake_program = linkProgram(gl, shaders::kBakeVertex, shaders::kBakeFragment);
    tangent_space_program = linkProgram(gl, shaders::kTangentSpaceVertex, shaders::kTangentSpaceFragment);
    gl.UseProgram(tangent_space_program);
    gl.Uniform1i(gl.GetUniformLocation(tangent_space_program, "u_high_normal"), kHighNormalUnit);
    grid_uniform = gl.GetUniformLocation(bake_program, "u_grid");
    for (Slot& slot : slots) {
      for (GLuint* name : slot.vertexArrays()) gl.GenVertexArrays(1, name);
      for (GLuint* name : slot.buffers()) gl.GenBuffers(1, name);
      for (GLuint* name : slot.textures()) gl.GenTextures(1, name);
      for (GLuint* name : slot.framebuffers()) gl.GenFramebuffers(1, name);
    }
  }

  ~Impl() {
    for (Slot& slot : slots) {
      if (slot.done) gl.DeleteSync(slot.done);  // a mapped buffer is unmapped as it is deleted
      for (GLuint* name : slot.framebuffers()) gl.DeleteFramebuffers(1, name);
      for (GLuint* name : slot.textures()) gl.DeleteTextures(1, name);
      for (GLuint* name : slot.buffers()) gl.DeleteBuffers(1, name);
      for (GLuint* name : slot.vertexArrays()) gl.DeleteVertexArrays(1, name);
    }
    gl.DeleteProgram(tangent_space_program);
    gl.DeleteProgram(bake_program);
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
  struct TargetFormat {
    GLint internal_format;
    GLenum format;
    const char* name;
  };
  // Both passes write octahedron-encoded normals. Measured in a batch run on
  // llvmpipe (463 tiles, 2 workers), the bake stage took 12.5-12.9 ms a tile
  // with the first pass in RG32F against 15.0-15.3 ms in RGBA32F (xyz and
  // coverage): half the bytes to write and read back in the second pass.
  static constexpr TargetFormat kHighNormalFormat{GL_RG32F, GL_RG, "RG32F"};
  static constexpr TargetFormat kTangentSpaceFormat{GL_RG32F, GL_RG, "RG32F"};

  void allocateTarget(GLuint framebuffer, GLuint texture, int size, TargetFormat format) {
    gl.BindFramebuffer(GL_FRAMEBUFFER, framebuffer);
    gl.BindTexture(GL_TEXTURE_2D, texture);
    gl.TexImage2D(GL_TEXTURE_2D, 0, format.internal_format, size, size, 0, format.format, GL_FLOAT, nullptr);
    gl.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
    gl.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
    gl.FramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, texture, 0);
    if (gl.CheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE) {
      throw InputError(std::string("gl: ") + format.name + " framebuffer of " + std::to_string(size) +
                       " texels is not supported");
    }
  }

  static GLsizeiptr readBackBytes(int size) { return GLsizeiptr(size) * size * GLsizeiptr(sizeof(glm::vec2)); }

  void prepareTargets(Slot& slot, int size) {
    if (size == slot.size) return;
    allocateTarget(slot.high_normal_framebuffer, slot.high_normal_texture, size, kHighNormalFormat);
    allocateTarget(slot.target_framebuffer, slot.target_texture, size, kTangentSpaceFormat);
    gl.BindBuffer(GL_PIXEL_PACK_BUFFER, slot.read_back_buffer);
    gl.BufferData(GL_PIXEL_PACK_BUFFER, readBackBytes(size), nullptr, GL_STREAM_READ);
    gl.BindBuffer(GL_PIXEL_PACK_BUFFER, 0);
    slot.size = size;
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

  void uploadHighRes(Slot& slot, const mesh::HighResMesh& high) {
    gl.BindVertexArray(slot.high_vao);
    slot.high_normals.upload(gl, GL_ARRAY_BUFFER, GLsizeiptr(high.normal.size() * sizeof(glm::vec3)),
                             high.normal.data());
    gl.VertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, 0, nullptr);
    gl.EnableVertexAttribArray(0);
  }

  void uploadLowPoly(Slot& slot, const mesh::TriangleMesh& low) {
    interleaved.clear();
    for (std::size_t i = 0; i < low.uv.size(); ++i) {
      const glm::vec3& n = low.normal[i];
      const glm::vec4& t = low.tangent[i];
      interleaved.insert(interleaved.end(), {low.uv[i].x, low.uv[i].y, n.x, n.y, n.z, t.x, t.y, t.z, t.w});
    }
    uploadVertices(slot.low_vao, slot.low_vertices, {2, 3, 4});
    slot.low_indices.upload(gl, GL_ELEMENT_ARRAY_BUFFER, GLsizeiptr(low.indices.size() * sizeof(std::uint32_t)),
                            low.indices.data());
    slot.low_index_count = GLsizei(low.indices.size());
  }

  // Queues the two passes and the read back of one tile; returns without
  // waiting for the GPU.
  void submit(Slot& slot, const mesh::HighResMesh& high, const mesh::TriangleMesh& low, int size) {
    // An earlier tile that failed half way may have left its error behind.
    while (gl.GetError() != GL_NO_ERROR) {
    }
    prepareTargets(slot, size);
    uploadLowPoly(slot, low);
    uploadHighRes(slot, high);
    gl.Viewport(0, 0, size, size);
    gl.Disable(GL_DEPTH_TEST);
    gl.Disable(GL_CULL_FACE);  // UV-space triangles may face either way

    // Pass 1: the high-res normal at every texel: the mesh's vertices, one on
    // each texel centre, drawn as points (see the top of this file).
    gl.BindFramebuffer(GL_FRAMEBUFFER, slot.high_normal_framebuffer);
    gl.ClearColor(kNoNormal, kNoNormal, 0, 0);
    gl.Clear(GL_COLOR_BUFFER_BIT);
    gl.UseProgram(bake_program);
    gl.Uniform2i(grid_uniform, high.cols, high.rows);
    gl.BindVertexArray(slot.high_vao);
    drawPoints(GLsizei(high.cols) * GLsizei(high.rows));

    // Pass 2: the low-poly mesh, writing that normal in its frame at every
    // texel it covers (all of them; cleared so none keeps an earlier tile).
    gl.BindFramebuffer(GL_FRAMEBUFFER, slot.target_framebuffer);
    gl.ClearColor(0, 0, 0, 0);
    gl.Clear(GL_COLOR_BUFFER_BIT);
    gl.UseProgram(tangent_space_program);
    gl.ActiveTexture(GLenum(GL_TEXTURE0 + kHighNormalUnit));
    gl.BindTexture(GL_TEXTURE_2D, slot.high_normal_texture);
    gl.BindVertexArray(slot.low_vao);
    gl.DrawElements(GL_TRIANGLES, slot.low_index_count, GL_UNSIGNED_INT, nullptr);

    // Into the slot's pack buffer: glReadPixels returns at once.
    gl.BindBuffer(GL_PIXEL_PACK_BUFFER, slot.read_back_buffer);
    gl.PixelStorei(GL_PACK_ALIGNMENT, 4);
    gl.ReadPixels(0, 0, size, size, GL_RG, GL_FLOAT, nullptr);
    gl.BindBuffer(GL_PIXEL_PACK_BUFFER, 0);
    // Before the fence: a tile that fails leaves its slot free for the next.
    checkError("bake");
    slot.done = gl.FenceSync(GL_SYNC_GPU_COMMANDS_COMPLETE, 0);
    if (!slot.done) {
      checkError("bake");
      throw InputError("gl: bake failed (no fence for its read back)");
    }
    gl.Flush();  // start the GPU on it now, not when the next tile is collected
  }

  // The first pass's draw, a scene at a time where that pays (see
  // kLlvmpipeScenePoints).
  void drawPoints(GLsizei count) {
    if (points_per_scene == 0) {
      gl.DrawArrays(GL_POINTS, 0, count);
      return;
    }
    for (GLsizei first = 0; first < count; first += points_per_scene) {
      gl.DrawArrays(GL_POINTS, first, std::min(points_per_scene, count - first));
      gl.Flush();
    }
  }

  // Waits for the slot's tile and maps its read back; on failure frees the
  // slot and throws.
  const glm::vec2* mapResult(Slot& slot) {
    const auto deadline = std::chrono::steady_clock::now() + kGpuStallLimit;
    constexpr GLuint64 kPollNs = 100'000'000;  // wake now and then to check the deadline
    GLenum state = GL_TIMEOUT_EXPIRED;
    while (state == GL_TIMEOUT_EXPIRED && std::chrono::steady_clock::now() < deadline) {
      state = gl.ClientWaitSync(slot.done, GL_SYNC_FLUSH_COMMANDS_BIT, kPollNs);
    }
    gl.DeleteSync(slot.done);
    slot.done = nullptr;
    if (state == GL_TIMEOUT_EXPIRED) {
      throw InputError("gl: the GPU did not finish a bake within " + std::to_string(kGpuStallLimit.count()) + " s");
    }
    if (state == GL_WAIT_FAILED) {
      checkError("waiting for a bake");
      throw InputError("gl: waiting for a bake failed");
    }
    gl.BindBuffer(GL_PIXEL_PACK_BUFFER, slot.read_back_buffer);
    const auto* texels = static_cast<const glm::vec2*>(
        gl.MapBufferRange(GL_PIXEL_PACK_BUFFER, 0, readBackBytes(slot.size), GL_MAP_READ_BIT));
    gl.BindBuffer(GL_PIXEL_PACK_BUFFER, 0);
    if (!texels) {
      checkError("mapping the read back");
      throw InputError("gl: mapping the read back failed");
    }
    slot.mapped = true;
    return texels;
  }

  void releaseResult(Slot& slot) {
    gl.BindBuffer(GL_PIXEL_PACK_BUFFER, slot.read_back_buffer);
    gl.UnmapBuffer(GL_PIXEL_PACK_BUFFER);
    gl.BindBuffer(GL_PIXEL_PACK_BUFFER, 0);
    slot.mapped = false;
    checkError("read back");
  }
};

GlBaker::GlBaker(std::unique_ptr<Context> context, int in_flight)
    : m_impl(std::make_unique<Impl>(std::move(context), in_flight)) {}
GlBaker::~GlBaker() = default;

std::string GlBaker::description() const { return m_impl->description; }

int GlBaker::inFlightLimit() const { return int(m_impl->slots.size()); }

GlBaker::Ticket GlBaker::submit(const mesh::HighResMesh& high, const mesh::TriangleMesh& low, int size) {
  Impl& s = *m_impl;
  for (std::size_t k = 0; k < s.slots.size(); ++k) {
    if (s.slots[k].taken()) continue;
    s.submit(s.slots[k], high, low, size);
    return Ticket(k);
  }
  throw std::logic_error("GlBaker::submit: every slot holds a tile that was not released");
}

GlBaker::Result GlBaker::mapResult(Ticket ticket) {
  Slot& slot = m_impl->slots.at(std::size_t(ticket));
  if (!slot.done) throw std::logic_error("GlBaker::mapResult: no tile drawing in that slot");
  return {m_impl->mapResult(slot), slot.size};
}

void GlBaker::releaseResult(Ticket ticket) {
  Slot& slot = m_impl->slots.at(std::size_t(ticket));
  if (!slot.mapped) throw std::logic_error("GlBaker::releaseResult: no mapped tile in that slot");
  m_impl->releaseResult(slot);
}

bake::NormalMap GlBaker::collect(Ticket ticket) {
  const Result result = mapResult(ticket);
  bake::NormalMap map = result.copy();
  releaseResult(ticket);
  return map;
}

bake::NormalMap GlBaker::bake(const mesh::HighResMesh& high, const mesh::TriangleMesh& low, int size) {
  return collect(submit(high, low, size));
}

bake::NormalMap GlBaker::Result::copy() const {
  bake::NormalMap map;
  map.size = size;
  map.texels.resize(std::size_t(size) * std::size_t(size));
  decodeOctahedra(texels, map.texels.size(), map.texels.data());
  return map;
}

}  // namespace terrabake::gl
