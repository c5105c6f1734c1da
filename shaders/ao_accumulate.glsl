// Progressive AO: one frame's (AO, depth) texels added into the running mean with additive
// blending (mrcheck/render/passes.py, FramePasses.ao). The first frame drawn writes with blending
// off, the others add u_weight * AO; only frame 0, drawn last, adds its depth (u_depth_weight 1)
// to the zeros before, so the depth the blur and the upsampling read is exactly its own. The copy
// back into the raw buffer is this pass with weights 1. One fetch per pixel and frame. AO is at most 1: the clamp keeps the background's
// mean of ones (1/N added N times) from rounding above it. A texel without depth is background:
// in the copy back, frame 0's background, whose mean holds the AO of the sub-pixel frames that
// covered it with geometry; it is 1 again, as a single frame's background is.
uniform sampler2D u_ao_depth;
uniform float u_weight;        // 1 / frames (1 for the copy back)
uniform float u_depth_weight;  // 1: write the depth (frame 0, the copy); 0: add none

out vec2 ao_depth;

void main() {
    vec2 texel = texelFetch(u_ao_depth, ivec2(gl_FragCoord.xy), 0).rg;
    float ao = texel.y > 0.0 ? texel.x : 1.0;
    ao_depth = vec2(min(ao * u_weight, 1.0), texel.y * u_depth_weight);
}
