// Shared by the AO passes: G-buffer access, the sample kernel and the 4x4 rotation tile.
// Defines injected from Python (mrcheck/ao/kernel.py): AO_SAMPLES, NOISE_SIZE, AO_STRIDE.
//
// AO_STRIDE 2 is half-resolution AO (the paper's "Half Res."): pass pixel (i, j) reads the
// full-resolution G-buffer at (2i, 2j) and uses intrinsics fx/2, fy/2, cx/2, cy/2, so every
// unprojected point is exactly that full-res pixel's surface point (a flat plane stays flat).
// Every pass writes its AO and the depth it read as one RG texel: the bilateral blur then
// reads one texel per tap instead of two (measured: 13 -> 8 ms per 1024x768 blur direction),
// and half-resolution AO needs no downsampling pass for the depth that blur and upsampling use.

uniform sampler2D u_depth;      // R32F linear camera-space z, 0 = background
uniform sampler2D u_normal;     // RGBA16F camera-space unit normal
uniform sampler2D u_noise;      // NOISE_SIZE^2 random unit vectors (reflection planes)
uniform vec4 u_intrinsics;      // fx, fy, cx, cy in pixels at this pass's resolution
uniform ivec2 u_size;           // this pass's resolution, pixels (the G-buffer's / AO_STRIDE)
uniform vec3 u_kernel[AO_SAMPLES];  // offsets inside the unit sphere, denser near the centre
uniform float u_intensity;      // AO strength: 0 none, 1 the paper's average, > 1 stronger

layout(location = 0) out vec2 ao_depth;    // x: AO, 1 = unoccluded; y: this pixel's depth (blur, upsampling)

// Depth and normal of this pass's pixel (background: depth 0).
float centre_depth(ivec2 ij) {
    float z = texelFetch(u_depth, ij * AO_STRIDE, 0).r;
    ao_depth.y = z;
    return z;
}

vec3 centre_normal(ivec2 ij) {
    return texelFetch(u_normal, ij * AO_STRIDE, 0).xyz;
}

// Camera-space point of pixel (u, v) (OpenCV pixel centres at integers) at depth z.
vec3 unproject(vec2 uv, float z) {
    return vec3((uv - u_intrinsics.zw) / u_intrinsics.xy * z, z);
}

// What every AO pass's main() starts from: its pixel ij, the depth z there, the camera-space
// point P and normal n, and the pixel's texel of the rotation tile (a unit vector).
struct AOPixel {
    ivec2 ij;
    float z;
    vec3 P;
    vec3 n;
    vec3 noise;
};

// The start of every AO pass's main():  AOPixel px; if (!ao_begin(px)) return;
// False on the background, whose texel it has written (AO 1, depth 0). A pass that does not
// read px.n (crytek) does not pay its fetch: the compiler drops the unused texelFetch.
bool ao_begin(out AOPixel px) {
    px.ij = ivec2(gl_FragCoord.xy);
    px.z = centre_depth(px.ij);
    if (px.z <= 0.0) { ao_depth.x = 1.0; return false; }
    px.P = unproject(vec2(px.ij), px.z);
    px.n = centre_normal(px.ij);
    px.noise = texelFetch(u_noise, px.ij % NOISE_SIZE, 0).xyz;
    return true;
}

// Nearest pixel q of camera-space point S and the depth stored there (texelFetch, one fetch,
// no filtering). Outside the image the fetch is clamped to the border and ``inside`` is false:
// the caller folds it into its final select (one unsigned compare, as negative q wraps to a
// huge value; measured 4-6 % faster than selecting the depth here).
float depth_at(vec3 S, out ivec2 q, out bool inside) {
    vec2 uv = S.xy / max(S.z, 1e-6) * u_intrinsics.xy + u_intrinsics.zw;
    q = ivec2(floor(uv + 0.5));
    inside = all(lessThan(uvec2(q), uvec2(u_size)));
    return texelFetch(u_depth, clamp(q, ivec2(0), u_size - 1) * AO_STRIDE, 0).r;
}

// Offset i reflected on this pixel's random plane (Mittring 2007) and flipped into the
// normal hemisphere (Filion & McNaughton 2008; thesis 4.3.2.2), as a unit-radius offset.
// ``n_reflected`` = reflect(n, plane), once per pixel: a reflection is symmetric, so
// dot(reflect(k, plane), n) = dot(k, reflect(n, plane)), and the flip test no longer waits for
// the reflected offset (same AO bit for bit, measured 3-4 % faster).
vec3 hemisphere_offset(int i, vec3 plane, vec3 n_reflected) {
    vec3 k = u_kernel[i];
    vec3 d = reflect(k, plane);
    return dot(k, n_reflected) < 0.0 ? -d : d;
}
