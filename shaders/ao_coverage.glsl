// Half-resolution AO, step 0: which half-resolution pixels have geometry, as a depth buffer
// (1 = geometry at full-resolution pixel (2i, 2j), 0 = background), so that the AO pass can
// skip the background with an early depth test like the full-resolution pass does with the
// G-buffer's own depth buffer (mrcheck/render/ao/base.py, draw_covered).
uniform sampler2D u_depth;   // full-resolution linear depth, 0 = background

void main() {
    float z = texelFetch(u_depth, ivec2(gl_FragCoord.xy) * 2, 0).r;
    gl_FragDepth = z > 0.0 ? 1.0 : 0.0;
}
