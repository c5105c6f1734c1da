// Vertex stage shared by every screen-space pass: one triangle that covers the viewport
// (three vertices from gl_VertexID, no vertex buffer). The fragment stages work in pixels
// through gl_FragCoord / texelFetch, so no texture coordinates are passed on.
// SCREEN_DEPTH: the triangle's depth, for passes that an early depth test confines to some
// pixels (mrcheck/render/ao/base.py, draw_covered; composite.glsl, MSAA).
#ifndef SCREEN_DEPTH
#define SCREEN_DEPTH 0.0
#endif
#if defined VERTEX_SHADER
void main() {
    vec2 p = vec2((gl_VertexID << 1) & 2, gl_VertexID & 2);
    gl_Position = vec4(p * 2.0 - 1.0, SCREEN_DEPTH, 1.0);
}
#endif
