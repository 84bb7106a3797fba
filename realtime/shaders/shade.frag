#version 430
// The shading pass: the paper's reflectance (docs/contract.md) with the diffuse irradiance and the
// glossy radiance of the scene's techniques (docs/architecture.md). The host #defines the scene's
// effects (HAS_DIFFUSE, HAS_GLOSSY, HAS_FRESNEL), each technique's own defines (DIFFUSE_SH9, ...) and
// the MATERIAL_* codes of scenes/model/materials.py.
in vec3 v_position;
in vec3 v_normal;
#ifdef REFLECTION_PER_VERTEX
in vec3 v_reflect;  // realtime.reflection = "per_vertex": the mirror direction of each vertex, interpolated
#endif
uniform vec3 camera_position;
uniform int material_type;  // MATERIAL_DIFFUSE, MATERIAL_PHONG, MATERIAL_BLEND
uniform vec3 kd;
uniform vec3 ks;
uniform float f0;
uniform int two_sided;  // material.two_sided (scenes/model/materials.py): 0 one-sided, 1 two-sided
out vec4 frag;
const float PI = 3.14159265358979323846;
// the fragment's shading normal (unit, facing the viewer), for techniques that need more than their
// argument (the light array's horizon, the shadow maps' normal offset); set first thing in main()
vec3 shading_normal;

// The chosen techniques' GLSL goes here (realtime.engine.gpu.shading_sources), occlusion and
// interreflection first (the light array's lobes call the shadow maps' light_visibility), then:
//   vec3 diffuse_irradiance(vec3 n): E(n), the cosine-weighted integral of the environment
//   vec3 glossy_radiance(vec3 r): the environment seen through the normalised Phong lobe about r
// @techniques

void main() {
    vec3 n = v_normal;
    float len = length(n);
    n = len > 0.0 ? n / len : vec3(0.0, 1.0, 0.0);
    vec3 v = normalize(camera_position - v_position);
    // Back faces and silhouettes, one rule for both renderers (scenes/model/materials.py): where the shading
    // normal faces away from the viewer, a one-sided material is black (its reference BSDF is zero for
    // n.v <= 0) and a two-sided one is shaded with the normal flipped (Mitsuba's twosided).
    if (dot(n, v) <= 0.0) {
        if (two_sided == 0) {
            frag = vec4(0.0, 0.0, 0.0, 1.0);
            return;
        }
        n = -n;  // reflect(-v, n) does not depend on the normal's sign: per-vertex reflection holds too
    }
    shading_normal = n;
    float n_dot_v = clamp(dot(n, v), 0.0, 1.0);
    vec3 Ld = vec3(0.0);
    vec3 Lg = vec3(0.0);
#ifdef HAS_DIFFUSE
    Ld = kd / PI * max(diffuse_irradiance(n), vec3(0.0));
#endif
#ifdef HAS_GLOSSY
#ifdef REFLECTION_PER_VERTEX
    Lg = ks * glossy_radiance(normalize(v_reflect));
#else
    Lg = ks * glossy_radiance(reflect(-v, n));
#endif
#endif
    // the techniques' shade entries: void f(n, v, inout Ld, inout Lg) (voxel cone tracing's visibility)
    // @shade entries
    vec3 color = material_type == MATERIAL_DIFFUSE ? Ld : Lg;
#ifdef HAS_FRESNEL
    if (material_type == MATERIAL_BLEND) {
        float F = f0 + (1.0 - f0) * pow(1.0 - n_dot_v, 5.0);  // Schlick, eq. 15
        color = (1.0 - F) * Ld + F * Lg;  // eq. 7
    }
#endif
    frag = vec4(max(color, vec3(0.0)), 1.0);
}
