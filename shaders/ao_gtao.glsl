// Ground-truth-based AO (GTAO): Jimenez, Wu, Pesce, Jarabo 2016, "Practical Realtime Strategies
// for Accurate Indirect Occlusion", section 4. Horizon-based and cosine-weighted: per slice the
// two horizons h1 <= 0 <= h2 are found by marching the depth buffer (eq. 4-6), clamped to the
// normal hemisphere (h1 = n + max(h1 - n, -pi/2), h2 = n + min(h2 - n, pi/2)), and the visible
// part [h1, h2] is integrated in closed form with the cosine weight (eq. 10; ao_slices.glsl).
//
// The radius is the vector mode's: r_px pixels on screen (r_S = r_px Z / f_y, optional world
// clamp). Distance attenuation: a sample at distance d raises the horizon by its elevation above
// the tangent times the reference's weight 1 / (1 + c (d/r)^2) within r (0 beyond), i.e. its
// horizon angle is blended from the side's open horizon (the tangent) towards its own, as XeGTAO
// blends (in cosines, with a linear falloff). Horizons are measured as that elevation against
// the tangent on each sample's own pixel ray (ao_slices.glsl, slice_sample: why). No thickness
// heuristic: every sample above the horizon occludes all below it (the halo behind thin objects
// that vbao addresses).
#include "ao_common.glsl"
#include "ao_slices.glsl"

void main() {
    AOPixel px;
    SlicePixel sp;
    if (!slice_begin(px, sp)) return;           // background

    float visible = 0.0, whole = 0.0;
    for (int i = 0; i < SLICES; ++i) {
        Slice s = make_slice(i, sp.rot, sp.V, px.n);
        float sin_n = sin(s.n), cos_n = cos(s.n);
        // each side's horizon as its lift above the tangent (0: open), attenuated by distance
        float lift_pos = 0.0, lift_neg = 0.0;
        for (int k = 0; k < SLICE_STEPS; ++k) {
            float offset = step_offset(k, sp.jitter, sp.r_proj);
            vec3 d;
            float lift;
            if (slice_sample(sp.p, s.dir, offset, px.P, px.n, sp.V, d, lift))
                lift_pos = max(lift_pos, lift * attenuation(dot(d, d), sp.r2));
            if (slice_sample(sp.p, -s.dir, offset, px.P, px.n, sp.V, d, lift))
                lift_neg = max(lift_neg, lift * attenuation(dot(d, d), sp.r2));
        }
        // h2 = n + min(h2 - n, pi/2), h1 = n + max(h1 - n, -pi/2) of the paper, as lifts
        float h2 = s.n + HALF_PI - min(lift_pos, PI);
        float h1 = min(s.n - HALF_PI + min(lift_neg, PI), h2);
        float g_lo = slice_G(s.n - HALF_PI, s.n, sin_n, cos_n);
        float g_hi = slice_G(s.n + HALF_PI, s.n, sin_n, cos_n);
        visible += s.len * (slice_G(h2, s.n, sin_n, cos_n) - slice_G(h1, s.n, sin_n, cos_n));
        whole += s.len * (g_hi - g_lo);
    }
    ao_depth.x = slice_ao(visible, whole);
}
