// The anti-aliased G-buffer's packing (mrcheck/render/antialias.py): llvmpipe writes every
// covered sample of every attachment, so the multisampled G-buffer's cost grows with its bytes
// per sample (measured on the cell's aisle, 1024x768: 1x 109 ms, 4x with the three attachments of
// the single-sampled G-buffer, 16 bytes, 312 ms, 4x with one RG32F attachment, 8 bytes, 156 ms).
// So each sample holds the linear depth (float) and one 32-bit word:
//
//   bit 31 front face | bit 30: 0, bit 29: 1 | bits 28-20 palette index | bits 19-0 normal
//
// the normal octahedron-encoded (Cigolle et al. 2014) at 10 bits per axis (at most 0.1 degree
// off), the albedo as an index in the scene's palette of part colours (mrcheck/render/gbuffer.py,
// up to 512). Bits 30-29 = 01 keep the word's float exponent in 64-127: a normal float, never
// NaN, infinity or a denormal that a driver might flush; the background's word is 0.

vec2 sign_not_zero(vec2 v) { return vec2(v.x >= 0.0 ? 1.0 : -1.0, v.y >= 0.0 ? 1.0 : -1.0); }

vec2 oct_encode(vec3 n) {
    vec2 p = n.xy / (abs(n.x) + abs(n.y) + abs(n.z));
    return n.z >= 0.0 ? p : (1.0 - abs(p.yx)) * sign_not_zero(p);
}

vec3 oct_decode(vec2 p) {
    vec3 n = vec3(p, 1.0 - abs(p.x) - abs(p.y));
    if (n.z < 0.0) n.xy = (1.0 - abs(n.yx)) * sign_not_zero(n.xy);
    return normalize(n);
}

float pack_surface(vec3 n, float albedo_index, bool front) {
    uvec2 q = uvec2(round((oct_encode(n) * 0.5 + 0.5) * 1023.0));
    uint word = (front ? 0x80000000u : 0u) | 0x20000000u | (uint(albedo_index) << 20) | (q.x << 10) | q.y;
    return uintBitsToFloat(word);
}

// (normal, palette index, front face) of a packed word; false for the background.
bool unpack_surface(float bits, out vec3 n, out int albedo_index, out bool front) {
    uint word = floatBitsToUint(bits);
    n = oct_decode(vec2(uvec2(word >> 10, word) & 1023u) / 1023.0 * 2.0 - 1.0);
    albedo_index = int((word >> 20) & 511u);
    front = (word & 0x80000000u) != 0u;
    return (word & 0x20000000u) != 0u;
}

// Two samples show the same surface when both are background, or their depths (at the centre)
// agree to SAME_DEPTH relative and their normals to SAME_NORMAL: coplanar triangles of one face
// are one surface, so the diagonals of a triangulated face are no edge.
const float SAME_DEPTH = 1e-5;     // float32 noise of two triangles' planes evaluated at one point
const float SAME_NORMAL = 2e-4;    // squared distance of the normals, 0.8 deg: not two facets

bool same_surface(float za, vec3 na, float zb, vec3 nb) {
    bool background = za <= 0.0 && zb <= 0.0;
    return background || (za > 0.0 && zb > 0.0 && abs(za - zb) <= SAME_DEPTH * za && dot(na - nb, na - nb) <= SAME_NORMAL);
}
