// Shared by the AO passes: G-buffer access, the sample kernel and the 4x4 rotation tile.
// Defines injected from Python (mrcheck/render/ao/kernel.py): AO_SAMPLES, NOISE_SIZE, AO_STRIDE.
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

// A sliver: a facet narrower than a pixel (the flank of a rib of corrugated cladding, a few
// centimetres deep, seen almost face on) that the G-buffer's one sample per pixel caught at this
// pixel but not at its neighbours on either side, which lie on one surface with another normal at
// about this depth. Its normal is a point sample of a feature the AO cannot resolve: the flank's
// hemisphere holds the wall it stands on, so the pixel reads strongly occluded, and the blur
// spreads that one pixel into a dark dot (the moire of the ribs with the pixel grid puts the dots
// on rows and arcs: docs/rendering.md, "The D2 pattern"). A sliver takes its neighbours' normal:
// the surface that covers most of the pixel's footprint.
const float SLIVER_COS = 0.9;      // normals this close are "the same surface"
const float SLIVER_DEPTH = 0.02;   // neighbours within this relative depth lie on the same surface

bool same_surface(vec3 na, vec3 nb, float za, float zb, float z) {
    return dot(na, nb) > SLIVER_COS && abs(za - z) < SLIVER_DEPTH * z && abs(zb - z) < SLIVER_DEPTH * z;
}

vec3 centre_normal(ivec2 ij) {
    ivec2 p = ij * AO_STRIDE;
    vec3 n = texelFetch(u_normal, p, 0).xyz;
    float z = texelFetch(u_depth, p, 0).r;
    ivec2 last = textureSize(u_normal, 0) - 1;
    for (int axis = 0; axis < 2; ++axis) {
        ivec2 step = axis == 0 ? ivec2(AO_STRIDE, 0) : ivec2(0, AO_STRIDE);
        ivec2 a = clamp(p - step, ivec2(0), last), b = clamp(p + step, ivec2(0), last);
        vec3 na = texelFetch(u_normal, a, 0).xyz, nb = texelFetch(u_normal, b, 0).xyz;
        if (dot(n, na) < SLIVER_COS && same_surface(na, nb, texelFetch(u_depth, a, 0).r, texelFetch(u_depth, b, 0).r, z))
            return normalize(na + nb);
    }
    return n;
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
