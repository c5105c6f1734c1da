// Half-resolution AO, step 2: depth-aware upsampling. Full-res pixel p sits at half-res
// coordinate p / 2 (see ao_downsample.glsl); the four surrounding half-res AO values are
// weighted bilinearly and by depth similarity, so AO does not leak across silhouettes. When
// no neighbour is on the same surface, the one with the closest depth is taken.
uniform sampler2D u_ao_half;
uniform sampler2D u_depth_half;
uniform sampler2D u_depth_full;
uniform ivec2 u_size_half;

const float DEPTH_TOLERANCE = 0.05;        // relative, as in blur_bilateral.glsl

out float ao;

void main() {
    ivec2 ij = ivec2(gl_FragCoord.xy);
    float z = texelFetch(u_depth_full, ij, 0).r;
    vec2 h = vec2(ij) * 0.5;
    ivec2 base = ivec2(floor(h));
    vec2 f = h - vec2(base);

    float sum = 0.0, weight = 0.0, best_dz = 3.4e38, best = 1.0;
    for (int k = 0; k < 4; ++k) {
        ivec2 o = ivec2(k & 1, k >> 1);
        ivec2 q = min(base + o, u_size_half - 1);
        float zq = texelFetch(u_depth_half, q, 0).r;
        float a = texelFetch(u_ao_half, q, 0).r;
        float d = (zq - z) / (max(z, 1e-30) * DEPTH_TOLERANCE);
        vec2 b = mix(1.0 - f, f, vec2(o));
        float w = b.x * b.y * exp(-d * d);
        sum += w * a;
        weight += w;
        float dz = abs(zq - z);
        best = dz < best_dz ? a : best;
        best_dz = min(dz, best_dz);
    }
    ao = z <= 0.0 ? 1.0 : (weight > 1e-4 ? sum / weight : best);
}
