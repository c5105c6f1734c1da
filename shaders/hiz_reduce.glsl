// Occlusion culling, step 1: the farthest depth of every HIZ_BLOCK x HIZ_BLOCK block of the
// G-buffer's linear depth after the occluders are drawn (mrcheck/render/culling.py). Background
// (depth 0) counts as infinitely far, so a block with any uncovered pixel hides nothing.
// One pass of HIZ_BLOCK^2 fetches per output texel (64 at 8x8: as many fetches as one
// full-resolution pass in total); the rest of the pyramid is built from this 1/64 read-back.
#if MSAA
uniform sampler2DMS u_depth;   // the anti-aliased G-buffer: the farthest of the pixel's samples
#else
uniform sampler2D u_depth;
#endif

out float far_depth;

void main() {
    ivec2 base = ivec2(gl_FragCoord.xy) * HIZ_BLOCK;
#if MSAA
    ivec2 last = textureSize(u_depth) - 1;
#else
    ivec2 last = textureSize(u_depth, 0) - 1;
#endif
    float far = 0.0;
    for (int j = 0; j < HIZ_BLOCK; ++j) {
        for (int i = 0; i < HIZ_BLOCK; ++i) {
            // clamped at the right/bottom edge: a repeated edge texel does not change the max
            ivec2 ij = min(base + ivec2(i, j), last);
#if MSAA
            for (int k = 0; k < MSAA; ++k) {
                float z = texelFetch(u_depth, ij, k).r;
                far = max(far, z > 0.0 ? z : 3.0e38);
            }
#else
            float z = texelFetch(u_depth, ij, 0).r;
            far = max(far, z > 0.0 ? z : 3.0e38);
#endif
        }
    }
    far_depth = far;
}
