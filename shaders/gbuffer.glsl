// Geometry pass: linear depth, camera-space normal, albedo.
//
// Camera space is OpenCV's (x right, y down, z forward). u_projection maps image row 0 to
// framebuffer row 0, so everything downstream reads pixel (u, v) at texel (u, v).
// u_model_view arrives per instance: view @ world computed in float64 on the CPU and cast to
// float32 only then, so float32 holds camera-relative coordinates only (large extents).

#if defined VERTEX_SHADER
in vec3 in_position;          // part-local, metres (re-centred on the part's bounding box)
in mat4 in_model_view;        // per instance: local -> camera
uniform mat4 u_projection;    // from K exactly, reversed-Z
out vec3 v_camera;            // camera-space position

void main() {
    vec4 p = in_model_view * vec4(in_position, 1.0);
    v_camera = p.xyz;
    gl_Position = u_projection * p;
}

#elif defined FRAGMENT_SHADER
in vec3 v_camera;
uniform vec3 u_albedo;        // linear RGB of the part
uniform float u_albedo_index; // its entry in the scene's palette (anti-aliasing's packed G-buffer)
uniform bool u_pack;          // drawing into the anti-aliased, multisampled G-buffer

#include "gbuffer_pack.glsl"

// x: linear camera-space z (> 0); 0 = background. y (u_pack): the packed normal, albedo and
// face (gbuffer_pack.glsl) for the multisampled G-buffer, whose single RG32F attachment this is;
// the single-sampled G-buffer's R32F attachment keeps x only.
layout(location = 0) out vec2 g_depth;
layout(location = 1) out vec4 g_normal;    // xyz: unit camera-space normal facing the camera
layout(location = 2) out vec4 g_albedo;    // rgb: albedo; a: 1 front face, 0 back face

void main() {
    // Face normal from the screen-space derivatives of the position: exact for the flat
    // triangles of CAD data, needs no normal attribute (less memory and bandwidth for 10 M
    // triangles) and always faces the camera, whatever the winding of the export.
    // d(P)/du x d(P)/dv points away from the camera for a visible surface, hence the minus.
    vec3 n = -normalize(cross(dFdx(v_camera), dFdy(v_camera)));
    g_normal = vec4(n, 0.0);
    g_depth = vec2(v_camera.z, u_pack ? pack_surface(n, u_albedo_index, gl_FrontFacing) : 0.0);
    g_albedo = vec4(u_albedo, gl_FrontFacing ? 1.0 : 0.0);
}
#endif
