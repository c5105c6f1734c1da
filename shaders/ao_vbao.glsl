// Visibility-bitmask AO (VBAO): Therrien, Levesque, Gilet 2023, "Screen Space Indirect Lighting
// with Visibility Bitmask", section 3. GTAO's slices (ao_slices.glsl), but each slice's normal
// hemisphere [n - pi/2, n + pi/2] is split into 32 sectors, one bit each, and every sample
// occludes only the sectors between the angles of its front point and its back point: the
// front pushed away from the camera by the thickness t (back = front - V t). So a thin object
// hides only the sectors it covers, and what lies behind it stays visible (a horizon method
// treats everything below the highest sample as occluded).
//
//   t_f, t_b = (h - (n - pi/2)) / pi, the front's and back's angle in the normal hemisphere
//   (measured as elevations above the tangent on the sample's own ray: ao_slices.glsl, why)
//   bits |= sectors floor(32 min(t_f, t_b)) .. + ceil(32 |t_f - t_b|)        (their listing 1)
//
// Departures, documented in docs/method.md: (1) the sectors are weighted by their cosine-weighted
// measure G(h_{k+1}) - G(h_k) (Jimenez eq. 10), not counted uniformly, so vbao estimates the
// same cosine-weighted AO as the reference and gtao; (2) the reference's distance attenuation
// 1 / (1 + c (d/r)^2) cannot weight a bit, so a sample occludes with that probability (a per-pixel,
// per-sample threshold; the blur averages it) and never beyond r; (3) the thickness is
// u_thickness * r_S, a multiple of the world sampling radius, so the result does not depend on
// the scene's unit or distance. Samples on or below the tangent plane (cos < EPS, as the
// vector mode's) occlude nothing: their whole segment lies below it, and float error on a plane
// would otherwise set the last sector.
#include "ao_common.glsl"
#include "ao_slices.glsl"

uniform float u_thickness;      // t / r_S

const float EPS = 0.02;
const float GOLDEN = 0.61803398875;
const int SECTORS = 32;

// The sectors a sample at ``d`` (from P) occludes, as a bitmask; ``side`` +1 or -1 says which
// side of the slice it lies on, ``u`` in [0, 1) is its attenuation threshold.
uint sample_bits(vec3 d, float lift, float side, vec3 V, vec3 N, float r2, float thickness, float u) {
    float d2 = dot(d, d);
    bool occludes = dot(d, N) > EPS * sqrt(d2) && u < attenuation(d2, r2);
    // the back point's elevation: the front's less the angle between front and back seen from P
    vec3 back = d - V * thickness;
    float spread = acos(clamp(dot(d, back) * inversesqrt(max(d2 * dot(back, back), 1e-30)), -1.0, 1.0));
    // angles from the - side's tangent, in units of pi: lift on the - side, pi - lift on the + side
    vec2 lifts = vec2(lift, lift - spread);
    vec2 t = clamp((side > 0.0 ? PI - lifts : lifts) / PI, 0.0, 1.0);
    float lo = min(t.x, t.y);
    uint start = uint(min(floor(lo * float(SECTORS)), float(SECTORS - 1)));
    uint count = uint(ceil(abs(t.x - t.y) * float(SECTORS)));
    uint mask = count > 0u ? (0xFFFFFFFFu >> (32u - min(count, 32u))) << start : 0u;
    return occludes ? mask : 0u;
}

// The cosine-weighted measure of the set sectors of ``bits`` in slice ``s``: G at the ends of
// each run of set bits (sector k spans h = n - pi/2 + pi k / 32 .. + pi / 32), two G per run;
// typically 0-2 runs (measured at 16 samples, 1280x1024, interleaved under load ~11: 3.1x the
// fetch floor this way, 4.3x summing all 32 sectors).
float sector_h(int k, float n) {
    return n - HALF_PI + PI * float(k) / float(SECTORS);
}

float occluded_measure(uint bits, float n, float sin_n, float cos_n) {
    float sum = 0.0;
    while (bits != 0u) {
        int start = findLSB(bits);
        uint rest = ~(bits >> uint(start));          // zeros where the run is
        int end = rest == 0u ? SECTORS : start + findLSB(rest);
        sum += slice_G(sector_h(end, n), n, sin_n, cos_n) - slice_G(sector_h(start, n), n, sin_n, cos_n);
        bits = end >= SECTORS ? 0u : bits & (0xFFFFFFFFu << uint(end));
    }
    return sum;
}

void main() {
    AOPixel px;
    SlicePixel sp;
    if (!slice_begin(px, sp)) return;           // background
    float thickness = u_thickness * sp.r_S;
    float u = fract(0.5 + 0.5 * px.noise.y + 0.25 * px.noise.x);   // attenuation thresholds, per pixel

    float visible = 0.0, whole = 0.0;
    for (int i = 0; i < SLICES; ++i) {
        Slice s = make_slice(i, sp.rot, sp.V, px.n);
        float sin_n = sin(s.n), cos_n = cos(s.n);
        uint bits = 0u;
        for (int k = 0; k < SLICE_STEPS; ++k) {
            float offset = step_offset(k, sp.jitter, sp.r_proj);
            vec3 d;
            float lift;
            u = fract(u + GOLDEN);
            if (slice_sample(sp.p, s.dir, offset, px.P, px.n, sp.V, d, lift))
                bits |= sample_bits(d, lift, 1.0, sp.V, px.n, sp.r2, thickness, u);
            u = fract(u + GOLDEN);
            if (slice_sample(sp.p, -s.dir, offset, px.P, px.n, sp.V, d, lift))
                bits |= sample_bits(d, lift, -1.0, sp.V, px.n, sp.r2, thickness, u);
        }
        float total = slice_G(s.n + HALF_PI, s.n, sin_n, cos_n) - slice_G(s.n - HALF_PI, s.n, sin_n, cos_n);
        visible += s.len * (total - occluded_measure(bits, s.n, sin_n, cos_n));
        whole += s.len * total;
    }
    ao_depth.x = slice_ao(visible, whole);
}
