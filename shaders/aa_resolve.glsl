// Anti-aliasing resolve (mrcheck/render/antialias.py): output pixel (i, j) from the 3 x 3
// samples (2i + a, 2j + b), a, b in {-1, 0, 1}, of the 2x composite, whose even samples are the
// pixel centres and odd ones the pixel edges: the trapezoid rule over the pixel's area, weights
// (1/4, 1/2, 1/4) along each axis. The source is an sRGB texture, so texelFetch returns linear
// light: the mean is taken in linear light (an edge pixel half covered by a white and a black
// surface is 50 % linear, not 50 % sRGB), and the sRGB target encodes it again.
uniform sampler2D u_color;     // the 2x composite, 2W x 2H

out vec4 color;

void main() {
    ivec2 centre = ivec2(gl_FragCoord.xy) * 2;
    ivec2 last = textureSize(u_color, 0) - 1;
    const float w[3] = float[3](0.25, 0.5, 0.25);
    vec3 sum = vec3(0.0);
    for (int b = -1; b <= 1; ++b)
        for (int a = -1; a <= 1; ++a)
            sum += w[a + 1] * w[b + 1] * texelFetch(u_color, clamp(centre + ivec2(a, b), ivec2(0), last), 0).rgb;
    color = vec4(sum, 1.0);
}
