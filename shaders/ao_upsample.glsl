// Half-resolution AO, step 3 (only when the AO buffer itself is wanted at full resolution;
// for the shaded image the composite upsamples on the fly): see ao_upsample_common.glsl.
#define AO_HALF 1
#include "ao_upsample_common.glsl"

uniform sampler2D u_depth_full;

out float ao;

void main() {
    ivec2 ij = ivec2(gl_FragCoord.xy);
    float z = texelFetch(u_depth_full, ij, 0).r;
    ao = z <= 0.0 ? 1.0 : upsampled_ao(vec2(ij), z);
}
