// Shared by the AO passes: G-buffer access, the sample kernel and the 4x4 rotation tile.
// Defines injected from Python (mrcheck/ao/kernel.py): AO_SAMPLES, NOISE_SIZE.

uniform sampler2D u_depth;      // R32F linear camera-space z, 0 = background
uniform sampler2D u_normal;     // RGBA16F camera-space unit normal
uniform sampler2D u_noise;      // NOISE_SIZE^2 random unit vectors (reflection planes)
uniform vec4 u_intrinsics;      // fx, fy, cx, cy in pixels at this pass's resolution
uniform ivec2 u_size;           // this pass's resolution, pixels
uniform vec3 u_kernel[AO_SAMPLES];  // offsets inside the unit sphere, denser near the centre
uniform float u_intensity;      // AO strength: 0 none, 1 the paper's average, > 1 stronger

out float ao;                   // 1 = unoccluded

// Camera-space point of pixel (u, v) (OpenCV pixel centres at integers) at depth z.
vec3 unproject(vec2 uv, float z) {
    return vec3((uv - u_intrinsics.zw) / u_intrinsics.xy * z, z);
}

// Nearest pixel of camera-space point S, and the depth stored there; 0 (background, which
// occludes nothing) when S falls outside the image. texelFetch, no filtering: one fetch.
float depth_at(vec3 S, out ivec2 q) {
    vec2 uv = S.xy / max(S.z, 1e-6) * u_intrinsics.xy + u_intrinsics.zw;
    q = ivec2(floor(uv + 0.5));
    ivec2 qc = clamp(q, ivec2(0), u_size - 1);
    float z = texelFetch(u_depth, qc, 0).r;
    return q == qc ? z : 0.0;
}

// Offset i reflected on this pixel's random plane (Mittring 2007) and flipped into the
// normal hemisphere (Filion & McNaughton 2008; thesis 4.3.2.2), as a unit-radius offset.
vec3 hemisphere_offset(int i, vec3 plane, vec3 n) {
    vec3 d = reflect(u_kernel[i], plane);
    return dot(d, n) < 0.0 ? -d : d;
}
