// Depth-aware upsampling of half-resolution AO, shared by ao_upsample.glsl (the AO buffer at
// full resolution, for --output-ao) and composite.glsl (fused, so no extra full-resolution
// pass is paid per frame). Full-res pixel p sits at half-res coordinate p / 2 (see
// ao_common.glsl, AO_STRIDE); the four surrounding half-res values are weighted bilinearly and by
// depth similarity, so AO does not leak across silhouettes; when no neighbour is on the same
// surface, the one with the closest depth is taken. Two textureGather calls fetch the 2x2
// footprint of AO and depth (components x and y of the half-resolution (AO, depth) texels),
// and the weights are computed four at a time.
uniform sampler2D u_ao_half;
uniform ivec2 u_size_half;

#include "depth_tolerance.glsl"   // DEPTH_TOLERANCE, shared with the bilateral blur

float upsampled_ao(ivec2 ij, float z) {
    vec2 h = vec2(ij) * 0.5;
    vec2 f = fract(h);
    vec2 uv = (floor(h) + 1.0) / vec2(u_size_half);  // bilinear footprint starts at floor(h)
    // gather order: x (0,1), y (1,1), z (1,0), w (0,0) relative to floor(h)
    vec4 zq = textureGather(u_ao_half, uv, 1);
    vec4 aq = textureGather(u_ao_half, uv, 0);
    vec4 bilinear = vec4((1.0 - f.x) * f.y, f.x * f.y, f.x * (1.0 - f.y), (1.0 - f.x) * (1.0 - f.y));
    vec4 d = (zq - z) / (max(z, 1e-30) * DEPTH_TOLERANCE);
    vec4 w = bilinear / (1.0 + d * d);
    float weight = dot(w, vec4(1.0));

    vec4 dz = abs(zq - z);
    vec4 pick = step(dz, vec4(min(min(dz.x, dz.y), min(dz.z, dz.w))));
    float fallback = dot(aq, pick) / dot(pick, vec4(1.0));
    return weight > 1e-3 ? dot(w, aq) / weight : fallback;
}
