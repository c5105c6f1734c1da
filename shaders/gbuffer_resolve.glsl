// Anti-aliasing, step 2 (mrcheck/render/antialias.py): the single-sampled G-buffer that the AO
// passes, the composite's inner pixels, the depth read-back and the picking read, from the 4x
// multisampled, packed one (gbuffer_pack.glsl). The geometry pass's fragment shader runs once
// per pixel, at its centre, and writes the same values to every sample its triangle covers, so
// each sample holds a triangle's values as the single-sampled pass writes them at the centre.
//
// Two samples show the same surface when both are background, or their depths (at the centre)
// agree to SAME_DEPTH relative and their normals to SAME_NORMAL: coplanar triangles of one face
// are one surface, so the diagonals of a triangulated face are no edge. The pixel takes the
// surface that covers most of its samples (the one most likely to cover the centre, which is no
// sample), the nearer one on a tie. A pixel whose samples are not all one surface is an edge
// pixel, which the composite shades again per sample. The depth buffer carries it, for early
// depth tests (llvmpipe then skips whole 4x4 blocks without running a shader): 0 background,
// 0.5 a surface, 1 an edge pixel; the AO passes run where it is above 0 (ao/base.py,
// draw_covered), the composite's edge pass where it is above 0.75.
uniform sampler2DMS u_packed;    // (depth, packed word) per sample
uniform sampler2D u_palette;     // the scene's part colours (mrcheck/render/gbuffer.py, Palette)

#include "gbuffer_pack.glsl"

const float SAME_DEPTH = 1e-5;     // float32 noise of two triangles' planes evaluated at one point
const float SAME_NORMAL = 2e-4;    // squared distance of the normals, 0.8 deg: not two facets

layout(location = 0) out float g_depth;
layout(location = 1) out vec4 g_normal;
layout(location = 2) out vec4 g_albedo;

bool same_surface(float za, vec3 na, float zb, vec3 nb) {
    bool background = za <= 0.0 && zb <= 0.0;
    return background || (za > 0.0 && zb > 0.0 && abs(za - zb) <= SAME_DEPTH * za && dot(na - nb, na - nb) <= SAME_NORMAL);
}

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
    int best = 0;
    int best_votes = 0;
    float best_far = 0.0;
    for (int k = 0; k < MSAA; ++k) {
        int votes = 0;
        for (int j = 0; j < MSAA; ++j)
            votes += int(same_surface(z[k], n[k], z[j], n[j]));
        float far = z[k] > 0.0 ? z[k] : 3.0e38;
        bool better = votes > best_votes || (votes == best_votes && far < best_far);
        best = better ? k : best;
        best_votes = better ? votes : best_votes;
        best_far = better ? far : best_far;
    }
    vec3 normal;
    int albedo_index;
    bool front;
    bool covered = unpack_surface(word[best].y, normal, albedo_index, front);
    vec3 albedo = texelFetch(u_palette, ivec2(albedo_index, 0), 0).rgb;
    g_depth = z[best];
    g_normal = vec4(covered ? normal : vec3(0.0), 0.0);
    g_albedo = vec4(covered ? albedo : vec3(0.0), front ? 1.0 : 0.0);
    gl_FragDepth = best_votes < MSAA ? 1.0 : (covered ? 0.5 : 0.0);
}
