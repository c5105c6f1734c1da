// Anti-aliasing, step 2 (mrcheck/render/antialias.py): the single-sampled G-buffer that the AO
// passes, the composite's inner pixels, the depth read-back and the picking read, from the 4x
// multisampled, packed one (gbuffer_pack.glsl). The geometry pass's fragment shader runs once
// per pixel, at its centre, and writes the same values to every sample its triangle covers, so
// each sample holds a triangle's values as the single-sampled pass writes them at the centre.
//
// Samples that show the same surface (same_surface, gbuffer_pack.glsl) vote for it. The pixel takes the
// surface that covers most of its samples (the one most likely to cover the centre, which is no
// sample), the nearer one on a tie. A pixel whose samples are not all one surface is an edge
// pixel, which the composite shades again. The depth buffer carries it, for early
// depth tests (llvmpipe then skips whole 4x4 blocks without running a shader): 0 background,
// 0.5 a surface, 1 an edge pixel; the AO passes run where it is above 0 (ao/base.py,
// draw_covered), the composite's edge pass where it is above 0.75. The normal's fourth channel
// holds which samples the pixel's surface covers (bit k: sample k), for the edge pass, which
// shades only the others (composite.glsl).
uniform sampler2DMS u_packed;    // (depth, packed word) per sample
uniform sampler2D u_palette;     // the scene's part colours (mrcheck/render/gbuffer.py, Palette)

#include "gbuffer_pack.glsl"

#if MSAA != 4
#error "the vote below is written out for 4 samples"
#endif

layout(location = 0) out float g_depth;
layout(location = 1) out vec4 g_normal;
layout(location = 2) out vec4 g_albedo;

void main() {
    ivec2 ij = ivec2(gl_FragCoord.xy);
    vec3 n[MSAA];
    float z[MSAA];
    vec2 word[MSAA];
    for (int k = 0; k < MSAA; ++k) {
        word[k] = texelFetch(u_packed, ij, k).rg;
        z[k] = word[k].x;
        int albedo_index;
        bool front;
        unpack_surface(word[k].y, n[k], albedo_index, front);
    }
    // same[k]: the samples that show sample k's surface, as bits; each pair compared once,
    // written out (a loop over pairs left llvmpipe indexing the array per pixel: 2.5x slower)
    int s01 = int(same_surface(z[0], n[0], z[1], n[1])), s02 = int(same_surface(z[0], n[0], z[2], n[2]));
    int s03 = int(same_surface(z[0], n[0], z[3], n[3])), s12 = int(same_surface(z[1], n[1], z[2], n[2]));
    int s13 = int(same_surface(z[1], n[1], z[3], n[3])), s23 = int(same_surface(z[2], n[2], z[3], n[3]));
    int same[4] = int[4](1 | s01 << 1 | s02 << 2 | s03 << 3, s01 | 2 | s12 << 2 | s13 << 3,
                         s02 | s12 << 1 | 4 | s23 << 3, s03 | s13 << 1 | s23 << 2 | 8);
    // the winner's values carried along by selects (llvmpipe runs a per-pixel array index slowly)
    int best_votes = 0;
    float best_far = 0.0;
    vec2 best_word = vec2(0.0);
    vec3 normal = vec3(0.0);
    int covers = 0;   // the samples of the pixel's surface, as bits
    for (int k = 0; k < MSAA; ++k) {
        int votes = bitCount(same[k]);
        float far = z[k] > 0.0 ? z[k] : 3.0e38;
        bool better = votes > best_votes || (votes == best_votes && far < best_far);
        best_votes = better ? votes : best_votes;
        best_far = better ? far : best_far;
        best_word = better ? word[k] : best_word;
        normal = better ? n[k] : normal;
        covers = better ? same[k] : covers;
    }
    int albedo_index;
    bool front;
    bool covered = unpack_surface(best_word.y, normal, albedo_index, front);
    vec3 albedo = texelFetch(u_palette, ivec2(albedo_index, 0), 0).rgb;
    g_depth = best_word.x;
    g_normal = vec4(covered ? normal : vec3(0.0), float(covers));
    g_albedo = vec4(covered ? albedo : vec3(0.0), front ? 1.0 : 0.0);
    gl_FragDepth = best_votes < MSAA ? 1.0 : (covered ? 0.5 : 0.0);
}
