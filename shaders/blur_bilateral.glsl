// Depth-aware Gaussian bilateral blur (Petschnigg et al. 2004, as the paper uses it), one
// separable direction per draw: (2 * BLUR_RADIUS + 1) taps along u_step. Taps across a depth
// discontinuity get a small weight, so AO does not bleed over object silhouettes; background
// taps get none. Input and output are (AO, depth) texels (ao_common.glsl): one fetch per tap,
// and the depth travels on to the next direction and to the upsampling.
uniform sampler2D u_ao_depth;
uniform ivec2 u_size;
uniform ivec2 u_step;                       // (1, 0) horizontal, (0, 1) vertical
uniform float u_weights[BLUR_RADIUS + 1];   // Gaussian, centre first (mrcheck/render/blur.py)

#include "depth_tolerance.glsl"   // DEPTH_TOLERANCE: a tap's weight falls to 1/e there

out vec2 ao_depth;

void main() {
    ivec2 ij = ivec2(gl_FragCoord.xy);
    vec2 centre = texelFetch(u_ao_depth, ij, 0).rg;
    float z = centre.y;
    if (z <= 0.0) { ao_depth = centre; return; }
    float inv_tol = 1.0 / (z * DEPTH_TOLERANCE);

    float sum = centre.x * u_weights[0];
    float weight = u_weights[0];
    for (int k = 1; k <= BLUR_RADIUS; ++k) {
        for (int side = -1; side <= 1; side += 2) {
            ivec2 q = clamp(ij + side * k * u_step, ivec2(0), u_size - 1);
            vec2 tap = texelFetch(u_ao_depth, q, 0).rg;
            float d = (tap.y - z) * inv_tol;
            float w = tap.y > 0.0 ? u_weights[k] * exp(-d * d) : 0.0;
            sum += w * tap.x;
            weight += w;
        }
    }
    ao_depth = vec2(sum / weight, z);
}
