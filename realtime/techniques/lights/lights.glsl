#if defined(DIFFUSE_LIGHTS) || defined(GLOSSY_LIGHTS)
// The light array (realtime/techniques/lights/lights.py): N distant lights, light i arriving from direction l_i (world,
// unit) with RGB power P_i (W m^-2: the irradiance it gives a surface facing it), through the paper's
// reflectance (docs/contract.md section 3), only above the surface (n . l > 0), each times its visibility:
//   diffuse:  E(n)  = sum_i P_i max(n . l_i, 0) V_i                       (then L_d = kd / pi E)
//   glossy:   L_g   = sum_i P_i (N + 1) / (2 pi) max(r . l_i, 0)^N V_i    (n . l_i > 0)
// V_i is light_visibility(i) of shadow_maps.glsl, or 1 without shadows.
layout(std430, binding = 5) readonly buffer LightDirections { vec4 light_direction[]; };
layout(std430, binding = 4) readonly buffer LightPowers { vec4 light_power[]; };
uniform int light_count;

#ifndef OCCLUSION_SHADOW_MAPS
float light_visibility(int i) { return 1.0; }
#endif

#ifdef DIFFUSE_LIGHTS
vec3 diffuse_irradiance(vec3 n) {
    vec3 E = vec3(0.0);
    for (int i = 0; i < light_count; ++i) {
        float c = dot(n, light_direction[i].xyz);
        if (c > 0.0) E += light_power[i].rgb * (c * light_visibility(i));
    }
    return E;
}
#endif

#ifdef GLOSSY_LIGHTS
uniform float phong_exponent;
vec3 glossy_radiance(vec3 r) {
    vec3 L = vec3(0.0);
    float norm = (phong_exponent + 1.0) / (2.0 * PI);
    for (int i = 0; i < light_count; ++i) {
        vec3 l = light_direction[i].xyz;
        float c = dot(r, l);
        if (c <= 0.0 || dot(shading_normal, l) <= 0.0) continue;
        // cos^N with 0^0 = 1 (a uniform lobe for N = 0), never pow(0, 0)
        float lobe = phong_exponent == 0.0 ? 1.0 : exp(phong_exponent * log(c));
        L += light_power[i].rgb * (norm * lobe * light_visibility(i));
    }
    return L;
}
#endif
#endif
