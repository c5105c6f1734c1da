// Composite: Blinn-Phong with one light (a headlight just above and left of the camera, or a directional "sun"),
// and an ambient term that the AO modulates (optionally the direct light too). Output: linear
// colour into an sRGB attachment, which encodes it (mrcheck/gl.py, srgb_texture).
uniform sampler2D u_depth;
uniform sampler2D u_normal;
uniform sampler2D u_albedo;
uniform sampler2D u_ao;        // (AO, depth) at full resolution (AO_HALF 0) ...
#if AO_HALF
#include "ao_upsample_common.glsl"  // ... or at half resolution, upsampled here (AO_HALF 1)
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

// Linear colour (tone-mapped) of G-buffer pixel ij; false on the background.
bool shade(ivec2 ij, out vec3 rgb) {
    float z = texelFetch(u_depth, ij, 0).r;
    if (z <= 0.0) { rgb = u_background; return false; }

    vec3 P = vec3((vec2(ij) - u_intrinsics.zw) / u_intrinsics.xy * z, z);
    vec3 n = texelFetch(u_normal, ij, 0).xyz;
    vec3 albedo = texelFetch(u_albedo, ij, 0).rgb;
#if AO_HALF
    float a = mix(1.0, upsampled_ao(ij, z), u_ao_weight);
#else
    float a = mix(1.0, texelFetch(u_ao, ij, 0).r, u_ao_weight);
#endif

    vec3 V = normalize(-P);
    vec3 H = normalize(u_light_dir + V);
    float diffuse = max(dot(n, u_light_dir), 0.0);
    float specular = diffuse > 0.0 ? pow(max(dot(n, H), 0.0), SHININESS) : 0.0;
    vec3 direct = (DIFFUSE * diffuse * albedo + SPECULAR * specular) * mix(1.0, a, u_ao_direct);
    rgb = tone(AMBIENT * a * albedo + direct);
    return true;
}

void main() {
    vec3 rgb;
    shade(ivec2(gl_FragCoord.xy), rgb);
    color = vec4(rgb, 1.0);
}
