#version 330 core
// Third pass: one triangle that covers the whole framebuffer, made from the
// vertex index alone (no vertex buffer).
void main() {
  vec2 corner = vec2(float((gl_VertexID & 1) << 2), float((gl_VertexID & 2) << 1));
  gl_Position = vec4(corner - 1.0, 0.0, 1.0);
}
