// Crytek SSAO (Mittring 2007, "Finding next gen: CryEngine 2"; the code of Kajalin 2009,
// ShaderX7) as reconstructed in Jakobsen's thesis, section 4.3.1 and appendix A.
//
// Samples fill a whole sphere around P -- no normal is used -- so on a flat surface half of
// them lie behind it and read as occluded: Crytek's famous grey flat walls (thesis fig. 17 C).
// This is kept on purpose; it is the comparison mode with the highest false occlusion.
//
// For each of AO_SAMPLES offsets (thesis 4.3.1.2; antipodal pairs, see mrcheck/render/ao/crytek.py):
//   S          = P + reflect(offset, plane) * R      sphere of constant camera-space radius R
//   Z(S)       = depth buffer at S's pixel
//   visible    = Z(S) > S.z                          the sample is in front of the surface
//   invalid    = saturate((P.z - Z(S)) / R)          the thesis' range check fRangeIsInvalid
//                                                    (4.3.1.3), in units of R
//   access     = lerp(visible ? 1 : 0, 0.5, invalid)  out-of-range occluders count as 0.5
//   background or outside the image: access = 1     (thesis: fSceneDepthS >= 1)
//   AO         = clamp(1 - intensity * (1 - sum(access) / N), 0, 1)
// With intensity 1 the AO is the mean accessibility, which is 0.5 on a flat plane. The
// thesis' final amplification saturate(a * a + a) (appendix A) is NOT applied, so that
// `intensity` is linear as in the other modes (with it a flat plane would read 0.75).
#include "ao_common.glsl"

uniform float u_radius_world;   // R, scene units (the thesis' offsetScale / d_max)

// Sample i's accessibility: P the pixel's camera-space point at depth z.
float sample_access(int i, vec3 P, float z, vec3 plane, float inv_r) {
    vec3 S = P + reflect(u_kernel[i], plane) * u_radius_world;   // whole sphere, no flip
    ivec2 q;
    bool inside;
    float zq = depth_at(S, q, inside);
    float visible = zq > S.z ? 1.0 : 0.0;
    float invalid = clamp((z - zq) * inv_r, 0.0, 1.0);           // thesis 4.3.1.3
    return (inside && zq > 0.0) ? mix(visible, 0.5, invalid) : 1.0;
}

void main() {
    AOPixel px;
    if (!ao_begin(px)) return;                  // background (px.n is not read: no normal)

    float inv_r = 1.0 / u_radius_world;

    float access = 0.0;
#define AO_SAMPLE(i) access += sample_access(i, px.P, px.z, px.noise, inv_r);
#include "ao_unroll.glsl"   // for (i = 0; i < AO_SAMPLES; ++i) AO_SAMPLE(i), unrolled
    ao_depth.x = clamp(1.0 - u_intensity * (1.0 - access / float(AO_SAMPLES)), 0.0, 1.0);
}
