#ifdef GLOSSY_SPLIT_SUM
// Karis' split sum for glTF's metallic-roughness material (realtime/techniques/split_sum/): the prefiltered
// radiance of the object's roughness (two levels of the GGX chain, the host chose them and their weight
// by the recipe's roughness <-> level mapping) times the GGX lobe's directional albedo from the DFG table.
uniform samplerCube split_sum_level_lo;  // the chain level at or below the object's lod
uniform samplerCube split_sum_level_hi;  // the next level (the same one when the lod is a level's)
uniform float split_sum_t;               // the lod's fraction: the weight of split_sum_level_hi
uniform sampler2D split_sum_dfg;         // (A, B) at (n.v, roughness), texel centres, bilinear, clamped

vec3 glossy_radiance(vec3 r) {
    return mix(textureLod(split_sum_level_lo, r, 0.0).rgb, textureLod(split_sum_level_hi, r, 0.0).rgb, split_sum_t);
}

// F_ibl(F0): the lobe's directional albedo with Schlick's F0, F0 A + B, and the recipe's compensation of
// multiple scattering (SPLIT_SUM_MULTISCATTER: ibl_fresnel.py holds the formulas and their numpy mirror)
vec3 split_sum_fresnel(vec3 F0, float n_dot_v) {
    vec2 ab = texture(split_sum_dfg, clamp(vec2(n_dot_v, roughness), vec2(0.0), vec2(1.0))).rg;
    vec3 single = F0 * ab.x + ab.y;
#if SPLIT_SUM_MULTISCATTER == 1
    // Fdez-Aguera 2019 as Khronos' getIBLGGXFresnel writes it, with its roughness-dependent Fresnel
    vec3 Fr = max(vec3(1.0 - roughness), F0) - F0;
    vec3 k_S = F0 + Fr * pow(1.0 - n_dot_v, 5.0);
    vec3 FssEss = k_S * ab.x + ab.y;
    float Ems = 1.0 - (ab.x + ab.y);
    vec3 F_avg = F0 + (1.0 - F0) / 21.0;
    return FssEss + Ems * FssEss * F_avg / (1.0 - F_avg * Ems);
#elif SPLIT_SUM_MULTISCATTER == 2
    // three.js' computeMultiscattering: the same from F0 A + B
    float Ems = 1.0 - (ab.x + ab.y);
    vec3 F_avg = F0 + (1.0 - F0) / 21.0;
    return single + single * F_avg * Ems / (1.0 - Ems * F_avg);
#elif SPLIT_SUM_MULTISCATTER == 3
    // Filament's and Babylon's energy compensation 1 + F0 (1 / (A + B) - 1)
    return single * (1.0 + F0 * (1.0 / (ab.x + ab.y) - 1.0));
#else
    return single;
#endif
}

// glTF's mix as the Khronos viewer composes IBL: dielectric = mix(diffuse, specular, F_ibl(0.04)),
// metal = F_ibl(base_color) specular, mixed by metallic. Returned as its two lobes, so that a visibility
// entry can scale each: Ld = (1 - metallic) (1 - F_d) diffuse, Lg = ((1 - metallic) F_d + metallic F_m) G.
void split_sum_lobes(float n_dot_v, vec3 diffuse, vec3 G, inout vec3 Ld, inout vec3 Lg) {
    vec3 F_d = split_sum_fresnel(vec3(PBR_DIELECTRIC_F0), n_dot_v);
    vec3 F_m = split_sum_fresnel(base_color, n_dot_v);
    Ld = (1.0 - metallic) * (1.0 - F_d) * diffuse;
    Lg = ((1.0 - metallic) * F_d + metallic * F_m) * G;
}
#endif
