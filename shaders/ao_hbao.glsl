// Horizon-based AO (Bavoil & Sainz 2008, "Image-Space Horizon-Based Ambient Occlusion",
// SIGGRAPH talk and ShaderX7; Puri section 2.4).
//
// Per pixel, HBAO_DIRS directions in the image plane (evenly spaced, rotated per pixel by the
// 4x4 tile) and HBAO_STEPS steps along each: AO_SAMPLES >= HBAO_DIRS * HBAO_STEPS depth fetches.
// The world radius R projects to r_px = R * f_y / Z pixels; the steps sit at (k + jitter) *
// r_px / (HBAO_STEPS + 1), k = 1..HBAO_STEPS, at least one pixel apart.
//
//   H_k   = Q_k - P, Q_k the visible surface point at step k's pixel q_k;
//           sin h_k = -H_k.z / |H_k|, the elevation towards the camera (-z) (Puri eq. h(H))
//   T_k   = the tangent plane's point on the ray through q_k, minus P;
//           sin t_k = -T_k.z / |T_k|, the tangent angle from the normal (Puri eq. t(T))
//   Bavoil & Sainz march along one line and use one tangent per direction. Steps are rounded
//   to pixel centres, which leaves that line; at grazing angles the one-tangent version then
//   reads a flat floor as occluded (measured: min 0.76). With the tangent taken along each
//   step's own ray, a plane gives sin h_k = sin t_k exactly; on an unrounded line T_k is
//   parallel to the direction's tangent, so this is the same quantity.
//   per step (Bavoil & Sainz, per-sample attenuation): if sin h_k - sin t_k > current horizon,
//           AO_d += W(r_k) * (sin h_k - sin t_k - current horizon), horizon = that value;
//           this telescopes to (sin h - sin t) * W for one occluder (Puri 2.4: AO = sin h - sin t)
//   W(r)  = 1 - r^2 / R^2; steps beyond R, on the background or outside the image are skipped
//   AO    = clamp(1 - intensity * mean over directions of AO_d, 0, 1)
//         (Bavoil & Sainz: A = 1 - 1/(2 pi) * integral over theta of (sin h - sin t) W)
// The horizon starts at SIN_BIAS above the tangent (their angle bias against tessellation
// artefacts).
#include "ao_common.glsl"

// HBAO_DIRS and HBAO_STEPS are injected from Python: mrcheck/render/ao/hbao.py,
// directions_and_steps, the one place that splits the AO_SAMPLES budget.

uniform float u_radius_world;   // R, scene units

const float SIN_BIAS = 0.02;    // angle bias (sine units, about 1.1 degrees)
const float TWO_PI = 6.28318530718;

void main() {
    AOPixel px;
    if (!ao_begin(px)) return;                  // background

    vec2 p = vec2(px.ij);
    vec3 P = px.P;
    vec3 n = px.n;
    float z = px.z;
    vec3 noise = px.noise;
    vec2 rot = normalize(noise.xy + vec2(1e-6, 0.0));   // per-pixel rotation (cos, sin)
    float jitter = 0.5 + 0.5 * noise.z;                 // per-pixel step offset in [0, 1]
    float R2 = u_radius_world * u_radius_world;
    float inv_R2 = 1.0 / R2;
    float step_px = max(u_radius_world * u_intrinsics.y / z / float(HBAO_STEPS + 1), 1.0);
    float nP = dot(n, P);

    float sum = 0.0;
    for (int d = 0; d < HBAO_DIRS; ++d) {
        float a = TWO_PI * float(d) / float(HBAO_DIRS);
        vec2 base = vec2(cos(a), sin(a));
        vec2 dir = vec2(base.x * rot.x - base.y * rot.y, base.x * rot.y + base.y * rot.x);
        float horizon = SIN_BIAS;                       // sin h - sin t, starts at the tangent
        float ao_d = 0.0;
        for (int k = 1; k <= HBAO_STEPS; ++k) {
            vec2 uv = p + dir * ((float(k) + jitter) * step_px);
            ivec2 q;
            bool inside;
            float zq = depth_at(unproject(uv, 1.0), q, inside);
            vec3 ray = unproject(vec2(q), 1.0);
            vec3 H = ray * zq - P;                                  // horizon vector
            vec3 T = ray * (nP / min(dot(n, ray), -1e-6)) - P;      // tangent (n faces the camera)
            float r2 = dot(H, H);
            float elev = -H.z * inversesqrt(max(r2, 1e-30)) + T.z * inversesqrt(max(dot(T, T), 1e-30));
            bool valid = inside && zq > 0.0 && r2 < R2;
            float rise = valid ? max(elev - horizon, 0.0) : 0.0;
            ao_d += rise * (1.0 - r2 * inv_R2);                 // W(r) = 1 - r^2 / R^2
            horizon += rise;
        }
        sum += ao_d;
    }
    ao_depth.x = clamp(1.0 - u_intensity * sum / float(HBAO_DIRS), 0.0, 1.0);
}
