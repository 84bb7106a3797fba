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
uniform int material_type;  // MATERIAL_DIFFUSE, MATERIAL_PHONG, MATERIAL_BLEND, MATERIAL_PBR
uniform vec3 kd;
uniform vec3 ks;
uniform float f0;
uniform vec3 base_color;  // MATERIAL_PBR (glTF 2.0 metallic-roughness): linear RGB
uniform float metallic;
uniform float roughness;
uniform int two_sided;  // material.two_sided (scenes/model/materials.py): 0 one-sided, 1 two-sided
out vec4 frag;
const float PI = 3.14159265358979323846;
// the fragment's shading normal (unit, facing the viewer), for techniques that need more than their
// argument (the light array's horizon, the shadow maps' normal offset); set first thing in main()
vec3 shading_normal;

// The chosen techniques' GLSL goes here (realtime.engine.gpu.shading_sources), occlusion and
// interreflection first (the light array's lobes call the shadow maps' light_visibility), then:
//   vec3 diffuse_irradiance(vec3 n): E(n), the cosine-weighted integral of the environment
//   vec3 glossy_radiance(vec3 r): the environment seen through the normalised Phong lobe about r (the split
//     sum's: through the GGX lobe of the object's roughness, with split_sum_lobes for the pbr material)
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
    vec3 E = vec3(0.0);  // the irradiance E(n)
    vec3 G = vec3(0.0);  // the glossy radiance
#ifdef HAS_DIFFUSE
    E = max(diffuse_irradiance(n), vec3(0.0));
    Ld = kd / PI * E;
#endif
#ifdef HAS_GLOSSY
#ifdef REFLECTION_PER_VERTEX
    G = glossy_radiance(normalize(v_reflect));
#else
    G = glossy_radiance(reflect(-v, n));
#endif
    Lg = ks * G;
#endif
#ifdef GLOSSY_SPLIT_SUM
    // glTF's metallic-roughness material: its Lambert term base_color / pi E (E = 0 where the scene has no
    // diffuse effect: all its pbr objects are metals) and its GGX lobe, composed as the Khronos viewer does
    if (material_type == MATERIAL_PBR) {
        split_sum_lobes(n_dot_v, base_color / PI * E, G, Ld, Lg);
    }
#endif
    // the techniques' shade entries: void f(n, v, inout Ld, inout Lg) (voxel cone tracing's visibility)
    // @shade entries
    vec3 color = material_type == MATERIAL_DIFFUSE ? Ld : Lg;
#ifdef GLOSSY_SPLIT_SUM
    if (material_type == MATERIAL_PBR) {
        color = Ld + Lg;
    }
#endif
#ifdef HAS_FRESNEL
    if (material_type == MATERIAL_BLEND) {
        float F = f0 + (1.0 - f0) * pow(1.0 - n_dot_v, 5.0);  // Schlick, eq. 15
        color = (1.0 - F) * Ld + F * Lg;  // eq. 7
    }
#endif
    frag = vec4(max(color, vec3(0.0)), 1.0);
}
