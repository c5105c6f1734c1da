// Half-resolution AO, step 1: half-resolution G-buffer. Half-res pixel (i, j) takes the depth
// and normal of full-res pixel (2i, 2j) unchanged (no averaging across edges), and the half-res
// intrinsics are fx/2, fy/2, cx/2, cy/2, so that pixel's centre is exactly the full-res one:
// unprojected points lie on the true surfaces, and a flat plane stays flat.
uniform sampler2D u_depth_full;
uniform sampler2D u_normal_full;

layout(location = 0) out float g_depth;
layout(location = 1) out vec4 g_normal;

void main() {
    ivec2 src = ivec2(gl_FragCoord.xy) * 2;
    g_depth = texelFetch(u_depth_full, src, 0).r;
    g_normal = texelFetch(u_normal_full, src, 0);
}
