// Shared by the compute and fragment shaders (inlined by realtime.gpu.shader_source).
// Conventions: docs/contract.md section 2. Mirrors scenes/environment/cubemap.py and scenes/environment/envmap.py exactly.
const float PI = 3.14159265358979323846;

// OpenGL cube-map face table: face coordinates sc, tc in [-1, 1] -> unnormalised direction.
vec3 face_direction(int face, float sc, float tc) {
    if (face == 0) return vec3(1.0, -tc, -sc);
    if (face == 1) return vec3(-1.0, -tc, sc);
    if (face == 2) return vec3(sc, 1.0, tc);
    if (face == 3) return vec3(sc, -1.0, -tc);
    if (face == 4) return vec3(sc, -tc, 1.0);
    return vec3(-sc, -tc, -1.0);
}

// Mitsuba's envmap lookup: u = atan2(x, -z) / 2pi, v = acos(y) / pi; bilinear with
// col = u W - 0.5 (wrapping) and row = v (H - 1) (align-corners). `env` holds rows top first.
vec3 env_lookup_uv(sampler2D env, float u, float v) {
    ivec2 size = textureSize(env, 0);
    int W = size.x, H = size.y;
    u -= floor(u);
    float col = u * float(W) - 0.5;
    float row = v * float(H - 1);
    float c0f = floor(col);
    float fc = col - c0f;
    // u is in [0, 1), so col is in [-0.5, W - 0.5) and c0 in [-1, W - 1]: wrap -1 by hand (GLSL's %
    // is undefined for negative operands, and llvmpipe gets it wrong unless W is a power of two)
    int c0 = int(c0f);
    if (c0 < 0) c0 += W;
    int c1 = c0 + 1 == W ? 0 : c0 + 1;
    int r0 = clamp(int(floor(row)), 0, max(H - 2, 0));
    int r1 = min(r0 + 1, H - 1);
    float fr = clamp(row - float(r0), 0.0, 1.0);
    vec3 top = mix(texelFetch(env, ivec2(c0, r0), 0).rgb, texelFetch(env, ivec2(c1, r0), 0).rgb, fc);
    vec3 bottom = mix(texelFetch(env, ivec2(c0, r1), 0).rgb, texelFetch(env, ivec2(c1, r1), 0).rgb, fc);
    return mix(top, bottom, fr);
}

vec3 env_lookup(sampler2D env, vec3 d) {
    d = normalize(d);
    float u = (d.x == 0.0 && d.z == 0.0) ? 0.0 : atan(d.x, -d.z) / (2.0 * PI);
    return env_lookup_uv(env, u, acos(clamp(d.y, -1.0, 1.0)) / PI);
}
