// The broad-lobe table's parameterisation (vct_lobe_table.comp writes it, vct_glossy_env.glsl reads it): Mitsuba's
// equirect angles, u = atan2(x, -z) / 2 pi in [0, 1), v = acos(y) / pi (scenes/environment/directions.py's
// direction_to_uv), texel (i, j) centred at ((i + 0.5) / W, (j + 0.5) / H) as GL samples it.
#ifndef VCT_LOBE_AXIS_GLSL
#define VCT_LOBE_AXIS_GLSL
vec3 vct_lobe_axis(vec2 uv) {
    float phi = 6.28318530717958647692 * uv.x, theta = 3.14159265358979323846 * uv.y;
    return vec3(sin(theta) * sin(phi), cos(theta), -sin(theta) * cos(phi));
}

vec2 vct_lobe_uv(vec3 d) {
    float u = (d.x == 0.0 && d.z == 0.0) ? 0.0 : atan(d.x, -d.z) / 6.28318530717958647692;
    return vec2(fract(u), acos(clamp(d.y, -1.0, 1.0)) / 3.14159265358979323846);
}
#endif
