// Composite: Blinn-Phong with one light (a headlight just above and left of the camera, or a directional "sun"),
// and an ambient term that the AO modulates (optionally the direct light too). Output: linear
// colour into an sRGB attachment, which encodes it (mrcheck/render/gl.py, srgb_texture).
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

const float AMBIENT = AMBIENT_VALUE;   // share of light that is indirect (a hall under diffuse light): what AO acts on
const float DIFFUSE = DIFFUSE_VALUE;   // (both injected from mrcheck/render/composite.py, SHADING)
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
// A sample of an edge pixel at ``offset`` from its centre, shaded with its own triangle's values
// (written at the pixel centre by the geometry pass) and the AO read depth-aware at its position.
vec3 shade_sample(ivec2 ij, vec2 offset, vec2 word) {
    vec3 n;
    int albedo_index;
    bool front;
    if (!unpack_surface(word.y, n, albedo_index, front)) return u_background;
    vec3 albedo = texelFetch(u_palette, ivec2(albedo_index, 0), 0).rgb;
    return lit(ij, word.x, n, albedo, mix(1.0, ao_at(vec2(ij) + offset, word.x), u_ao_weight));
}

// An edge pixel's samples that its resolved surface does not cover (bits of the normal's fourth
// channel, gbuffer_resolve.glsl): the first pass shaded that surface, this one adds the others,
// each surface shaded once at its first sample and weighted by the samples it covers; alpha is
// the resolved surface's share. Blended (ONE, SRC_ALPHA) into the sRGB target in linear light,
// the sum is the mean of the four samples' colours (half white, half black is 50 % linear, not
// sRGB). Two other surfaces are told apart; a fourth (four surfaces in one pixel) counts as the
// third. Shading one sample per surface instead of all four is what makes the pass cheap; the
// choice is made with selects, not indices (llvmpipe runs a per-pixel array index slowly).
vec4 shade_others(ivec2 ij) {
    int covers = int(texelFetch(u_normal, ij, 0).w + 0.5);
    vec2 first = vec2(0.0), second = vec2(0.0);
    vec2 first_at = vec2(0.0), second_at = vec2(0.0);
    vec3 first_n = vec3(0.0);
    bool have_first = false, have_second = false;
    float in_first = 0.0, in_second = 0.0;
    for (int k = 0; k < 4; ++k) {
        vec2 word = texelFetch(u_packed, ij, k).rg;
        vec3 n;
        int albedo_index;
        bool front;
        unpack_surface(word.y, n, albedo_index, front);
        bool other = ((covers >> k) & 1) == 0;
        bool opens = other && !have_first;
        first = opens ? word : first;
        first_n = opens ? n : first_n;
        first_at = opens ? SAMPLE_OFFSET[k] : first_at;
        have_first = have_first || opens;
        bool with_first = other && same_surface(first.x, first_n, word.x, n);
        bool rest = other && !with_first;
        second = rest && !have_second ? word : second;
        second_at = rest && !have_second ? SAMPLE_OFFSET[k] : second_at;
        have_second = have_second || rest;
        in_first += with_first ? 1.0 : 0.0;
        in_second += rest ? 1.0 : 0.0;
    }
    vec3 sum = in_first * shade_sample(ij, first_at, first);
    if (have_second) sum += in_second * shade_sample(ij, second_at, second);
    return vec4(0.25 * sum, 0.25 * float(bitCount(covers)));
}

// Anti-aliasing's edge pass: after the pass without MSAA has shaded every pixel once, the
// pixels that gbuffer_resolve.glsl marked as edges (an early depth test, SCREEN_DEPTH) get their
// other surfaces added. (A branch per pixel in one pass was slower: llvmpipe ran both sides.)
void main() {
    color = shade_others(ivec2(gl_FragCoord.xy));
}
#else
void main() {
    ivec2 ij = ivec2(gl_FragCoord.xy);
    color = vec4(shade(ij, texelFetch(u_depth, ij, 0).r, texelFetch(u_albedo, ij, 0)), 1.0);
}
#endif
