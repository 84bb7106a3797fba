#version 430
// Display pass: Reinhard photographic tone mapping, then sRGB (mirrors scenes/model/tonemap.py).
in vec2 v_ndc;
uniform sampler2D hdr;
uniform float scale;   // key / L_avg * 2^exposure
uniform float white;
out vec4 frag;

vec3 srgb(vec3 x) {
    x = clamp(x, 0.0, 1.0);
    return mix(1.055 * pow(x, vec3(1.0 / 2.4)) - 0.055, 12.92 * x, lessThanEqual(x, vec3(0.0031308)));
}

void main() {
    vec4 c = texelFetch(hdr, ivec2(gl_FragCoord.xy), 0);
    vec3 x = clamp(c.rgb * scale, 0.0, white);
    vec3 ld = x * (1.0 + x / (white * white)) / (1.0 + x);
    frag = vec4(srgb(ld), c.a);
}
