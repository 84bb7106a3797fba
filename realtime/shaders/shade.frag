#version 430
// The paper's per-pixel shading (design.md section 3). Compiled with only the effects the
// scene needs: HAS_DIFFUSE, HAS_GLOSSY, HAS_FRESNEL are #defined by the host.
in vec3 v_position;
in vec3 v_normal;
uniform vec3 camera_position;
uniform int material_type;  // 0 diffuse, 1 phong, 2 blend
uniform vec3 kd;
uniform vec3 ks;
uniform float exponent;
uniform float f0;
uniform samplerCube env_cube;
uniform float level_lod;    // mip level of the selected face size s: log2(base / s)
uniform float lod_bias;
uniform float face_size;
uniform float max_lod;
uniform int lod_mapping;    // 0 paper (bias only), 1 McGuire et al. 2013
layout(std430, binding = 2) readonly buffer SH { mat4 M[3]; vec4 coeffs[9]; };
out vec4 frag;
const float PI = 3.14159265358979323846;

void main() {
    vec3 n = v_normal;
    float len = length(n);
    n = len > 0.0 ? n / len : vec3(0.0, 1.0, 0.0);
    vec3 v = normalize(camera_position - v_position);
    float n_dot_v = clamp(dot(n, v), 0.0, 1.0);
    vec3 Ld = vec3(0.0);
    vec3 Lg = vec3(0.0);
#ifdef HAS_DIFFUSE
    // E(n) = n^T M n per channel (Ramamoorthi & Hanrahan 2001, eq. 12); never negative
    vec4 n4 = vec4(n, 1.0);
    vec3 E = vec3(dot(n4, M[0] * n4), dot(n4, M[1] * n4), dot(n4, M[2] * n4));
    Ld = kd / PI * max(E, vec3(0.0));
#endif
#ifdef HAS_GLOSSY
    vec3 r = reflect(-v, n);
    float offset = 0.0;
    if (lod_mapping == 1)  // a cosine-power lobe of exponent N covers 2 pi / (N + 1) sr
        offset = max(0.0, log2(face_size * sqrt(3.0)) - 0.5 * log2(exponent + 1.0));
    float lod = clamp(level_lod + offset + lod_bias, 0.0, max_lod);
    Lg = ks * textureLod(env_cube, r, lod).rgb;
#endif
    vec3 color = material_type == 0 ? Ld : Lg;
#ifdef HAS_FRESNEL
    if (material_type == 2) {
        float F = f0 + (1.0 - f0) * pow(1.0 - n_dot_v, 5.0);  // Schlick, eq. 15
        color = (1.0 - F) * Ld + F * Lg;  // eq. 7
    }
#endif
    frag = vec4(max(color, vec3(0.0)), 1.0);
}
