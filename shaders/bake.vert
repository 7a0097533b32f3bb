#version 330 core
// Flattens the high-res mesh into UV space: each vertex goes to its (u, v).
// Clip y = 2v - 1 puts v = 0 (north) in framebuffer row 0, which is the
// first row glReadPixels returns, so the image needs no flip.
layout(location = 0) in vec2 a_uv;
layout(location = 1) in vec3 a_normal;  // high-res surface normal, tile frame

out vec3 v_normal;

void main() {
  v_normal = a_normal;
  gl_Position = vec4(a_uv * 2.0 - 1.0, 0.0, 1.0);
}
