// Standard SSAO, the paper's D3: normal-oriented hemisphere kernel with a constant
// camera-space radius R in scene units and a depth-delta range check (Filion & McNaughton
// 2008, "StarCraft II"; Jakobsen's thesis section 4.3.2). Its screen footprint shrinks as
// R * f_y / Z, which is why its effect fades with distance (paper section 3).
//
//   delta = S.z - Z(S)      > 0: the visible surface is in front of the sample point
//   o     = 1 / (1 + c * (delta / R)^2)  counted when BIAS * R < delta < R (range check)
//   AO    = clamp(1 - intensity * sum(o) / N, 0, 1)
// The thesis writes the attenuation with delta in scene units times a depth scale; we express
// delta in units of R so that c means the same here as in the vector method.
#include "ao_common.glsl"

uniform float u_radius_world;   // R, scene units (metres for parts with declared units)
uniform float u_falloff;        // c

const float BIAS = 0.02;        // fraction of R: depth deltas below it are the surface itself

// Sample i's term: P the pixel's camera-space point.
float sample_term(int i, vec3 P, vec3 plane, vec3 n_reflected, float inv_r) {
    vec3 S = P + hemisphere_offset(i, plane, n_reflected) * u_radius_world;
    ivec2 q;
    bool inside;
    float zq = depth_at(S, q, inside);
    float delta = (S.z - zq) * inv_r;
    float o = 1.0 / (1.0 + u_falloff * delta * delta);
    return (inside && zq > 0.0 && delta > BIAS && delta < 1.0) ? o : 0.0;
}

void main() {
    AOPixel px;
    if (!ao_begin(px)) return;                  // background

    vec3 plane = px.noise;
    vec3 n_reflected = reflect(px.n, plane);    // for hemisphere_offset's flip
    float inv_r = 1.0 / u_radius_world;

    float sum = 0.0;
#define AO_SAMPLE(i) sum += sample_term(i, px.P, plane, n_reflected, inv_r);
#include "ao_unroll.glsl"   // for (i = 0; i < AO_SAMPLES; ++i) AO_SAMPLE(i), unrolled
    ao_depth.x = clamp(1.0 - u_intensity * sum / float(AO_SAMPLES), 0.0, 1.0);
}
