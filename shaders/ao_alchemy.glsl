// Alchemy AO (McGuire, Osman, Bukowski & Hennessy 2011, "The Alchemy Screen-Space Ambient
// Obscurance Algorithm", HPG; Puri section 2.5).
//
// AO_SAMPLES points uniformly on a disk parallel to the image plane of world radius R around
// P; its projection, r_px = R * f_y / Z pixels (Loos & Sloan's construction, Puri fig. 2.11),
// is sampled with the kernel's (x, y) (a disk, see mrcheck/render/ao/alchemy.py) rotated per pixel by
// the 4x4 tile. The visible surface point Q_i at each sample's pixel gives v_i = Q_i - P.
//
// The paper's final estimator (McGuire et al. eq. 10; Puri's last equation):
//   A = max(0, 1 - (2 sigma / s) * sum max(0, v_i . n + z_C beta) / (v_i . v_i + eps))^k
// The paper's camera looks down -z (z_C < 0), so z_C beta is a bias that *subtracts*; with
// OpenCV's z > 0 it reads  max(0, v_i . n - beta * z).  Our constants:
//   v_i measured in units of R  -- the paper's sigma has absorbed pi * u, a length; we take
//       sigma_paper = intensity * R, which makes the result independent of the scene unit
//   sigma = intensity (1 = the paper's baseline), k = CONTRAST = 1 (the paper's baseline),
//   beta = BETA = 1e-4 (bias relative to the depth), eps = EPS = 1e-4 (in R^2; the paper:
//       "within two orders of magnitude of 0.0001 indistinguishable").
// Samples on the background or outside the image count in s with no obscurance.
#include "ao_common.glsl"

uniform float u_radius_world;   // R, scene units

const float BETA = 1e-4;
const float EPS = 1e-4;
const float CONTRAST = 1.0;     // k

// Sample i's term: p the pixel, P its camera-space point, n its normal.
float sample_term(int i, vec2 p, vec3 P, vec3 n, vec2 rot, float r_px, float inv_r, float bias) {
    vec2 o = u_kernel[i].xy;
    vec2 uv = p + vec2(o.x * rot.x - o.y * rot.y, o.x * rot.y + o.y * rot.x) * r_px;
    ivec2 q;
    bool inside;
    float zq = depth_at(unproject(uv, 1.0), q, inside);
    vec3 v = (unproject(vec2(q), zq) - P) * inv_r;
    float o_i = max(dot(v, n) - bias, 0.0) / (dot(v, v) + EPS);
    return (inside && zq > 0.0) ? o_i : 0.0;
}

void main() {
    AOPixel px;
    if (!ao_begin(px)) return;                  // background

    vec2 p = vec2(px.ij);
    vec2 rot = normalize(px.noise.xy + vec2(1e-6, 0.0));
    float inv_r = 1.0 / u_radius_world;
    float r_px = u_radius_world * u_intrinsics.y / px.z;   // the disk's radius on screen
    float bias = BETA * px.z * inv_r;                      // beta * z_C, in units of R

    float sum = 0.0;
#define AO_SAMPLE(i) sum += sample_term(i, p, px.P, px.n, rot, r_px, inv_r, bias);
#include "ao_unroll.glsl"   // for (i = 0; i < AO_SAMPLES; ++i) AO_SAMPLE(i), unrolled
    ao_depth.x = pow(max(0.0, 1.0 - 2.0 * u_intensity / float(AO_SAMPLES) * sum), CONTRAST);
}
