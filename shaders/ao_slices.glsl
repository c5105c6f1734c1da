// Shared by the slice-based AO passes, ao_gtao.glsl and ao_vbao.glsl: the screen-constant
// radius (as the vector mode's), the slices and their sample positions, and the cosine-weighted
// slice integral of Jimenez et al. 2016 ("Practical Realtime Strategies for Accurate Indirect
// Occlusion", section 4, eq. 10). Include after ao_common.glsl.
//
// SLICES and SLICE_STEPS are injected from Python (mrcheck/render/ao/gtao.py, slices_and_steps):
// SLICES directions in [0, pi) rotated per pixel by the 4x4 tile, SLICE_STEPS samples on each
// side of the pixel, 2 * SLICES * SLICE_STEPS <= AO_SAMPLES depth fetches.
//
// Angles h in a slice are measured from the view vector V (pixel to camera), positive towards
// the slice's +dir side; the slice's projected normal sits at angle n, length len. Over the
// slice the cosine-weighted measure is cos(h - n) |sin h| dh (Jimenez eq. 3-7; |sin h| is the
// Jacobian of the slice parameterisation), whose integral from 0 to h is
//   a(h) = (cos n - cos(2h - n) + 2 h sin n) / 4          (eq. 10, one side)
// so G(h) = sign(h) a(h) is an antiderivative on (-pi, pi) and the measure of [lo, hi] is
// G(hi) - G(lo). The whole normal hemisphere of a slice, [n - pi/2, n + pi/2], measures
// cos n + n sin n.
//
// Normalisation (a documented departure from the paper, which divides by the exact total): the
// pass returns sum(len * visible) / sum(len * whole) over its slices. The paper's estimator
// averages len * visible and is 1 on a plane only on average over slice rotations (per pixel it
// varies with n); the ratio is 1 exactly on any plane and converges to the same value.

uniform float u_radius_px;      // r_px: radius on screen, pixels at this pass's resolution
uniform vec2 u_radius_clamp;    // world radius limits; (0, 3.4e38) = no clamp
uniform float u_falloff;        // c of the attenuation 1 / (1 + c (d / r)^2), as in the reference

const float PI = 3.14159265359;
const float HALF_PI = 1.57079632679;

struct Slice {
    vec2 dir;       // unit screen direction of the slice's + side
    vec3 dir3;      // the camera-space direction that screen direction unprojects to (z = 0)
    float n;        // signed angle of the projected normal from V
    float len;      // length of the projected normal (its weight)
};

// World radius r_S = r_px * Z / f_y, clamped (NOTES 1, 6 as in ao_vector.glsl), and its projection.
float world_radius(float z) {
    return clamp(u_radius_px * z / u_intrinsics.y, u_radius_clamp.x, u_radius_clamp.y);
}

Slice make_slice(int i, vec2 rot, vec3 V, vec3 N) {
    Slice s;
    float a = PI * float(i) / float(SLICES);
    vec2 base = vec2(cos(a), sin(a));
    s.dir = vec2(base.x * rot.x - base.y * rot.y, base.x * rot.y + base.y * rot.x);
    // points of the screen line p + t dir unproject into the plane spanned by P and dir3
    s.dir3 = normalize(vec3(s.dir / u_intrinsics.xy, 0.0));
    vec3 ortho = normalize(s.dir3 - dot(s.dir3, V) * V);   // in-slice, perpendicular to V, + side
    vec3 axis = cross(s.dir3, V);                           // the slice plane's normal
    axis *= inversesqrt(max(dot(axis, axis), 1e-30));
    vec3 pn = N - axis * dot(N, axis);
    s.len = length(pn);
    float cos_n = clamp(dot(pn, V) / max(s.len, 1e-6), -1.0, 1.0);
    s.n = sign(dot(pn, ortho)) * acos(cos_n);
    return s;
}

// What the slice passes' main() starts from, beyond ao_begin's AOPixel: the pixel as a vec2,
// the view vector V (P to the camera), the tile's slice rotation (cos, sin) and step jitter in
// [0, 1], the world radius r_S, its square and its projection in pixels (r_px unless clamped).
struct SlicePixel {
    vec2 p;
    vec3 V;
    vec2 rot;
    float jitter;
    float r_S;
    float r2;
    float r_proj;
};

// ao_begin, then the SlicePixel; false on the background (written by ao_begin).
bool slice_begin(out AOPixel px, out SlicePixel sp) {
    if (!ao_begin(px)) return false;
    sp.p = vec2(px.ij);
    sp.V = normalize(-px.P);
    sp.rot = normalize(px.noise.xy + vec2(1e-6, 0.0));
    sp.jitter = 0.5 + 0.5 * px.noise.z;
    sp.r_S = world_radius(px.z);
    sp.r2 = sp.r_S * sp.r_S;
    sp.r_proj = sp.r_S * u_intrinsics.y / px.z;
    return true;
}

// G(h) = sign(h) a(h), the antiderivative of the slice's cosine-weighted measure (above).
float slice_G(float h, float n, float sin_n, float cos_n) {
    float a = (cos_n - cos(2.0 * h - n) + 2.0 * h * sin_n) * 0.25;
    return h < 0.0 ? -a : a;
}

// Offset (pixels) of step k on a side: quadratic in (k + jitter) / SLICE_STEPS, so more
// samples fall near the pixel (as the kernels of the other modes), at least one pixel out.
float step_offset(int k, float jitter, float r_proj) {
    float t = (float(k) + jitter) / float(SLICE_STEPS);
    return 1.0 + t * t * max(r_proj - 1.0, 0.0);
}

// The visible surface point at pixel offset ``offset`` along ``dir`` and whether it is one
// (inside the image, not background): ``delta`` = that point - P, and ``lift`` = its elevation
// above the tangent plane, seen from P: the angle between delta and T, T the tangent plane's
// point on the same pixel ray (minus P), negative below the plane.
// Why the tangent on the sample's own ray (as ao_hbao.glsl does): samples are rounded to pixel
// centres, which leaves the slice plane, and the angle of an off-plane point from V is not the
// in-slice tangent angle n +- pi/2: measured against that, a grazing floor read as occluded
// (GTAO on the sample cell's floor: a visible speckle in the unblurred AO, 320x240; how dark
// was not measured). P, delta and T lie in one plane (the pixel ray's), so the angle between
// delta and T is the sample's elevation there: a plane gives lift 0 exactly, and on an
// unrounded slice line it is the paper's horizon angle less the tangent's, |(n +- pi/2) - h|.
// One acos per sample.
bool slice_sample(vec2 p, vec2 dir, float offset, vec3 P, vec3 N, vec3 V, out vec3 delta, out float lift) {
    ivec2 q;
    bool inside;
    float zq = depth_at(unproject(p + dir * offset, 1.0), q, inside);
    vec3 ray = unproject(vec2(q), 1.0);
    delta = ray * zq - P;
    vec3 T = ray * (dot(N, P) / min(dot(N, ray), -1e-6)) - P;    // N faces the camera
    float c = dot(delta, T) * inversesqrt(max(dot(delta, delta) * dot(T, T), 1e-30));
    float angle = acos(clamp(c, -1.0, 1.0));
    lift = dot(delta, N) > 0.0 ? angle : -angle;
    return inside && zq > 0.0;
}

// The distance attenuation of the reference, 1 / (1 + c (d / r)^2) within r, 0 beyond.
float attenuation(float d2, float r2) {
    return d2 < r2 ? 1.0 / (1.0 + u_falloff * d2 / r2) : 0.0;
}

// The AO value written from the visible share of the slices' measure (intensity as the others).
float slice_ao(float visible, float whole) {
    float occluded = 1.0 - visible / max(whole, 1e-6);
    return clamp(1.0 - u_intensity * occluded, 0.0, 1.0);
}
