// Composite: Blinn-Phong with one light (a headlight just above and left of the camera, or a directional "sun"),
// and an ambient term that the AO modulates (optionally the direct light too). Output: linear
// colour into an sRGB attachment, which encodes it (mrcheck/gl.py, srgb_texture).
uniform sampler2D u_depth;
uniform sampler2D u_normal;
uniform sampler2D u_albedo;
uniform sampler2D u_ao;        // (AO, depth) at full resolution (AO_HALF 0) ...
#include "ao_upsample_common.glsl"  // ... or at half resolution, upsampled here (AO_HALF 1)
#if MSAA
// Anti-aliasing (mrcheck/render/antialias.py): the 4x multisampled G-buffer beside the single-
// sampled one (gbuffer_resolve.glsl). SAMPLE_OFFSETS (injected): the samples' offsets from the
// pixel centre in texel axes, the standard 4x pattern (mrcheck/render/antialias.py).
uniform sampler2DMS u_packed;    // (depth, packed word) per sample (gbuffer_pack.glsl)
uniform sampler2D u_palette;     // the scene's part colours
#include "gbuffer_pack.glsl"
const vec2 SAMPLE_OFFSET[4] = SAMPLE_OFFSETS;
#endif
uniform vec4 u_intrinsics;     // fx, fy, cx, cy
uniform vec3 u_light_dir;      // camera space, unit, towards the light
uniform vec3 u_background;     // linear RGB
uniform float u_ao_weight;     // 0: Phong (D1), 1: AO applied
uniform float u_ao_direct;     // 0: AO darkens ambient only, 1: also the direct light
uniform int u_tone;            // index in TONES (mrcheck/render/settings.py): 0 filmic, 1 clip

const float AMBIENT = 0.60;    // share of light that is indirect (a hall under diffuse light): what AO acts on
const float DIFFUSE = 0.45;
const float SPECULAR = 0.12;
const float SHININESS = 40.0;

// The filmic tone curve (docs/rendering.md, "Light and tone"): exposure, then linear light up to
// KNEE unchanged (darks and mid-tones, where AO acts, keep their exact ratios), above it a shoulder
// that rolls off towards WHITE with slope 1 at the knee (C1), so the headlight's brightest
// surfaces (ambient + diffuse + specular up to 1.17 of the albedo) stay below saturation and keep
// the AO's darkening visible instead of clipping it away. The sRGB target encodes the result.
const float EXPOSURE = EXPOSURE_VALUE;
const float KNEE = KNEE_VALUE;
const float WHITE = WHITE_VALUE;

vec3 tone(vec3 x) {
    if (u_tone == 1) return clamp(x, 0.0, 1.0);      // clip: the renders before the tone curve
    x = max(x * EXPOSURE, 0.0);
    vec3 shoulder = KNEE + (WHITE - KNEE) * (1.0 - exp(-(x - KNEE) / (WHITE - KNEE)));
    return mix(x, shoulder, step(KNEE, x));
}

out vec4 color;

// Tone-mapped linear colour of a surface point seen through pixel ij at depth z.
vec3 lit(ivec2 ij, float z, vec3 n, vec3 albedo, float a) {
    vec3 P = vec3((vec2(ij) - u_intrinsics.zw) / u_intrinsics.xy * z, z);
    vec3 V = normalize(-P);
    vec3 H = normalize(u_light_dir + V);
    float diffuse = max(dot(n, u_light_dir), 0.0);
    float specular = diffuse > 0.0 ? pow(max(dot(n, H), 0.0), SHININESS) : 0.0;
    vec3 direct = (DIFFUSE * diffuse * albedo + SPECULAR * specular) * mix(1.0, a, u_ao_direct);
    return tone(AMBIENT * a * albedo + direct);
}

// AO at pixel position p (texel axes) for a surface at depth z: at an AO texel (the pixel
// centre) read directly; between texels (half resolution, or a multisample's position) depth-aware.
float ao_at(vec2 p, float z) {
#if AO_HALF
    return upsampled_ao(p, z);
#else
    return depth_aware_ao(u_ao, textureSize(u_ao, 0), p, z);
#endif
}

// The pixel's colour from the single-sampled G-buffer (z, albedo: fetched by the caller).
vec3 shade(ivec2 ij, float z, vec4 albedo) {
    if (z <= 0.0) return u_background;
#if AO_HALF
    float a = upsampled_ao(vec2(ij), z);
#else
    float a = texelFetch(u_ao, ij, 0).r;
#endif
    return lit(ij, z, texelFetch(u_normal, ij, 0).xyz, albedo.rgb, mix(1.0, a, u_ao_weight));
}

#if MSAA
// An edge pixel: each sample shaded with its own triangle's values (written at the pixel centre
// by the geometry pass) and the AO read depth-aware at its own position, averaged in linear
// light (the sRGB target encodes the mean: half white, half black is 50 % linear, not sRGB).
vec3 shade_samples(ivec2 ij) {
    vec3 sum = vec3(0.0);
    for (int k = 0; k < 4; ++k) {
        vec2 word = texelFetch(u_packed, ij, k).rg;
        vec3 n;
        int albedo_index;
        bool front;
        if (unpack_surface(word.y, n, albedo_index, front)) {
            vec3 albedo = texelFetch(u_palette, ivec2(albedo_index, 0), 0).rgb;
            float a = mix(1.0, ao_at(vec2(ij) + SAMPLE_OFFSET[k], word.x), u_ao_weight);
            sum += lit(ij, word.x, n, albedo, a);
        } else {
            sum += u_background;
        }
    }
    return 0.25 * sum;
}
#endif

#if MSAA
// Anti-aliasing's edge pass: after the pass without MSAA has shaded every pixel once, the
// pixels that gbuffer_resolve.glsl marked as edges (an early depth test, SCREEN_DEPTH) again
// per sample. (A branch per pixel in one pass was slower: llvmpipe ran both of its sides.)
void main() {
    color = vec4(shade_samples(ivec2(gl_FragCoord.xy)), 1.0);
}
#else
void main() {
    ivec2 ij = ivec2(gl_FragCoord.xy);
    color = vec4(shade(ij, texelFetch(u_depth, ij, 0).r, texelFetch(u_albedo, ij, 0)), 1.0);
}
#endif
