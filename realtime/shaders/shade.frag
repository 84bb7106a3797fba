#version 430
// The shading pass: the paper's reflectance (design.md section 3) with the diffuse irradiance and
// the glossy radiance of the scene's techniques (design.md section 9). The host #defines the
// scene's effects (HAS_DIFFUSE, HAS_GLOSSY, HAS_FRESNEL), one DIFFUSE_* and one GLOSSY_* technique
// (each included file below compiles only under its own define) and the MATERIAL_* codes of
// scenes/materials.py.
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
uniform int two_sided;  // material.two_sided (scenes/materials.py): 0 one-sided, 1 two-sided
out vec4 frag;
const float PI = 3.14159265358979323846;
// the fragment's shading normal (unit, facing the viewer), for techniques that need more than their
// argument (the light array's horizon, the shadow maps' normal offset); set first thing in main()
vec3 shading_normal;

// vec3 diffuse_irradiance(vec3 n): E(n), the cosine-weighted integral of the environment
#include "diffuse_sh9.glsl"
#include "diffuse_sh_n.glsl"
#include "diffuse_irradiance_map.glsl"
#include "diffuse_prt.glsl"
// float light_visibility(int i), then both lobes of the light array
#include "shadow_maps.glsl"
#include "lights.glsl"
// vec3 glossy_radiance(vec3 r): the environment seen through the normalised Phong lobe about r
#include "glossy_box.glsl"
#include "glossy_prefiltered.glsl"
// void vct_shade(n, v, Ld, Lg): voxel cone tracing's visibility and gathered bounce (realtime/vct.py)
#include "vct.glsl"

void main() {
    vec3 n = v_normal;
    float len = length(n);
    n = len > 0.0 ? n / len : vec3(0.0, 1.0, 0.0);
    vec3 v = normalize(camera_position - v_position);
    // Back faces and silhouettes, one rule for both renderers (scenes/materials.py): where the shading
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
#if defined(VCT_OCCLUSION) || defined(VCT_INTERREFLECTION)
    vct_shade(n, v, Ld, Lg);
#endif
    vec3 color = material_type == MATERIAL_DIFFUSE ? Ld : Lg;
#ifdef HAS_FRESNEL
    if (material_type == MATERIAL_BLEND) {
        float F = f0 + (1.0 - f0) * pow(1.0 - n_dot_v, 5.0);  // Schlick, eq. 15
        color = (1.0 - F) * Ld + F * Lg;  // eq. 7
    }
#endif
    frag = vec4(max(color, vec3(0.0)), 1.0);
}
