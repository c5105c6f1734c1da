// Depth-aware reading of an (AO, depth) buffer between its texels, shared by ao_upsample.glsl
// (half-resolution AO at full resolution, for --output-ao) and composite.glsl (the same fused
// into the shading, so no extra full-resolution pass is paid per frame; and the AO of an
// anti-aliased edge pixel's samples, which lie a quarter pixel off the AO's texel centres).
// The four texels around the position are weighted bilinearly and by depth similarity, so AO
// does not leak across silhouettes; when no neighbour is on the same surface, the one with the
// closest depth is taken. Two textureGather calls fetch the 2x2 footprint of AO and depth
// (components x and y of the (AO, depth) texels), and the weights are computed four at a time.
#include "depth_tolerance.glsl"   // DEPTH_TOLERANCE, shared with the bilateral blur

// AO at texel coordinate h of ``ao_depth`` (texel centres at integers), for a surface at depth z.
float depth_aware_ao(sampler2D ao_depth, ivec2 size, vec2 h, float z) {
    vec2 f = fract(h);
    vec2 uv = (floor(h) + 1.0) / vec2(size);  // bilinear footprint starts at floor(h)
    // gather order: x (0,1), y (1,1), z (1,0), w (0,0) relative to floor(h)
    vec4 zq = textureGather(ao_depth, uv, 1);
    vec4 aq = textureGather(ao_depth, uv, 0);
    vec4 bilinear = vec4((1.0 - f.x) * f.y, f.x * f.y, f.x * (1.0 - f.y), (1.0 - f.x) * (1.0 - f.y));
    vec4 d = (zq - z) / (max(z, 1e-30) * DEPTH_TOLERANCE);
    vec4 w = bilinear / (1.0 + d * d);
    float weight = dot(w, vec4(1.0));

    vec4 dz = abs(zq - z);
    vec4 pick = step(dz, vec4(min(min(dz.x, dz.y), min(dz.z, dz.w))));
    float fallback = dot(aq, pick) / dot(pick, vec4(1.0));
    return weight > 1e-3 ? dot(w, aq) / weight : fallback;
}

#if AO_HALF
// Half-resolution AO: full-res pixel p sits at half-res coordinate p / 2 (see ao_common.glsl, AO_STRIDE).
uniform sampler2D u_ao_half;
uniform ivec2 u_size_half;

float upsampled_ao(vec2 p, float z) {
    return depth_aware_ao(u_ao_half, u_size_half, p * 0.5, z);
}
#endif
