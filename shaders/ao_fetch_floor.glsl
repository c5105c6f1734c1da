// Benchmark kernel, not a render mode: the "fetch floor" of an AO pass. It reads the same
// number of depth texels as an AO pass with AO_SAMPLES samples (1 centre + AO_SAMPLES) with
// trivial arithmetic, so an AO pass time divided by this one says how much the arithmetic
// costs on top of the memory traffic. AO_STRIDE 2 is the half-resolution pass's floor: pixel
// (i, j) reads the full-resolution depth at (2i, 2j), as ao_common.glsl does.
uniform sampler2D u_depth;
uniform ivec2 u_size;                  // this pass's resolution (the depth's / AO_STRIDE)
uniform ivec2 u_offsets[AO_SAMPLES];   // pixel offsets inside the sampling radius, at this resolution

out float ao;

void main() {
    ivec2 ij = ivec2(gl_FragCoord.xy);
    float sum = texelFetch(u_depth, ij * AO_STRIDE, 0).r;
    if (sum <= 0.0) { ao = 1.0; return; }   // background, skipped as in the AO passes
#define AO_SAMPLE(i) sum += texelFetch(u_depth, clamp(ij + u_offsets[i], ivec2(0), u_size - 1) * AO_STRIDE, 0).r;
#include "ao_unroll.glsl"   // unrolled like the AO passes' sample loops
    ao = sum;
}
