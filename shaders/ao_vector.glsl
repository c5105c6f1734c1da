// Vector-based SSAO: Scheer & Keutel, "Screen Space Ambient Occlusion for Virtual and Mixed
// Reality Factory Planning", section 3, with the corrections of docs/papers_notes.md (NOTES).
//
// For each of AO_SAMPLES view-space offsets (NOTES 5): the sample P + offset * r_S is
// projected to the image; the *visible surface point* O at that pixel is the occluder
// candidate (NOTES 2), v = O - P the occlusion vector. It counts only inside the normal
// hemisphere, cos(v, n) > EPS, which is why a flat plane gets no occlusion at all: every
// candidate lies in the plane and cos = 0 (paper fig. 1).
//
//   o(v) = cos(v, n) / (1 + c * (|v| / r_S)^2)          paper eq. 1 + quasi-normalisation
//   r_S  = r_px * Z_p / f_y                             NOTES 1 (the paper prints d / Z_p)
//   AO   = clamp(1 - intensity * 2 * sum(o) / N, 0, 1)  NOTES 4: misses and samples below
//                                                       the hemisphere count in N as open
// The 2: offsets are uniform over the hemisphere, and the cosine-weighted occlusion
// (1/pi) * integral(V cos dw) equals 2 * E_uniform[V cos]. So intensity 1 gives an unbiased
// estimate of the definition (attenuation aside): a point in a 90-degree crease -> about 0.5.
// r_px (the paper's r_B * s_scene) is the sampling radius in pixels, so its projection is the
// same at every depth, and |v| / r_S makes the result independent of the scene's unit.
#include "ao_common.glsl"

uniform float u_radius_px;      // r_B * s_scene of the paper: radius on screen, pixels
uniform vec2 u_radius_clamp;    // world radius limits (NOTES 6); (0, 3.4e38) = no clamp
uniform float u_falloff;        // c, the paper's one artistic parameter

const float EPS = 0.02;         // cos threshold: rejects in-plane candidates whose float
                                // error would otherwise read as grazing occluders

// Sample i's term o(v): P the pixel's camera-space point, n its normal.
float sample_term(int i, vec3 P, vec3 n, vec3 plane, vec3 n_reflected, float r_S, float c_over_r2) {
    vec3 S = P + hemisphere_offset(i, plane, n_reflected) * r_S;
    ivec2 q;
    bool inside;
    float zq = depth_at(S, q, inside);
    vec3 v = unproject(vec2(q), zq) - P;     // occlusion vector to the visible surface
    float len2 = dot(v, v);
    float cos_vn = dot(v, n) * inversesqrt(max(len2, 1e-30));
    float o = cos_vn / (1.0 + c_over_r2 * len2);
    return (inside && zq > 0.0 && cos_vn > EPS) ? o : 0.0;   // background occludes nothing
}

void main() {
    AOPixel px;
    if (!ao_begin(px)) return;                  // background

    vec3 plane = px.noise;
    vec3 n_reflected = reflect(px.n, plane);    // for hemisphere_offset's flip
    float r_S = clamp(u_radius_px * px.z / u_intrinsics.y, u_radius_clamp.x, u_radius_clamp.y);
    float c_over_r2 = u_falloff / (r_S * r_S);

    float sum = 0.0;
#define AO_SAMPLE(i) sum += sample_term(i, px.P, px.n, plane, n_reflected, r_S, c_over_r2);
#include "ao_unroll.glsl"   // for (i = 0; i < AO_SAMPLES; ++i) AO_SAMPLE(i), unrolled
    ao_depth.x = clamp(1.0 - u_intensity * 2.0 * sum / float(AO_SAMPLES), 0.0, 1.0);
}
