#if defined(VCT_OCCLUSION) || defined(VCT_INTERREFLECTION)
// Voxel cone tracing in the shading pass (realtime/techniques/vct/vct.py): `occlusion = "vct"` multiplies the
// environment's diffuse irradiance by the diffuse cones' visibility and its glossy radiance by the
// glossy cone's; `interreflection = "vct"` adds what the same cones gather from the voxels, through
// the paper's reflectance (L_d = kd / pi E, L_g = ks L).
#include "vct_trace.glsl"
uniform float vct_glossy_tan;  // tan of this object's glossy cone half-angle (from its Phong exponent)
uniform float vct_glossy_exponent;  // its Phong exponent N (the lobe's share above the horizon)

void vct_shade(vec3 n, vec3 v, inout vec3 Ld, inout vec3 Lg) {
#ifdef HAS_DIFFUSE
    vec4 g = vct_diffuse(v_position, n, 0.0);
#ifdef VCT_OCCLUSION
    Ld *= g.a;
#endif
#ifdef VCT_INTERREFLECTION
    Ld += kd / PI * g.rgb;
#endif
#endif
#ifdef HAS_GLOSSY
    vec3 r = reflect(-v, n);
    float h = vct_local_voxel(v_position);
    vec4 s = vct_cone(v_position + vct_normal_voxels * h * n, r, vct_glossy_tan, vct_start_voxels * h, 0.0,
                      v_position, n);
#ifdef VCT_OCCLUSION
    Lg *= 1.0 - s.a;
#endif
#ifdef VCT_INTERREFLECTION
    Lg += ks * vct_lobe_above(dot(n, r), vct_glossy_exponent) * s.rgb;
#endif
#endif
}
#endif
