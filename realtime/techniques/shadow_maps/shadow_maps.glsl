#ifdef OCCLUSION_SHADOW_MAPS
// Shadow maps of the light array (realtime/techniques/shadow_maps/shadow_maps.py): one orthographic depth map per light,
// tiled in one depth atlas; percentage-closer filtering with the hardware's bilinear depth compare
// (sampler2DShadow, LINEAR) at 2x2 taps half a texel apart: a 3x3-texel tent.
layout(std430, binding = 6) readonly buffer ShadowMatrices { mat4 shadow_matrix[]; };  // world -> light NDC
uniform sampler2DShadow shadow_atlas;
uniform int shadow_tiles;       // tiles per row of the atlas
uniform float shadow_size;      // texels per tile side
uniform float shadow_normal_offset;  // world units: the receiver moves this far along its normal
uniform float shadow_depth_bias;     // in [0, 1] depth units

float light_visibility(int i) {
    vec3 p = v_position + shadow_normal_offset * shading_normal;
    vec4 q = shadow_matrix[i] * vec4(p, 1.0);
    vec3 ndc = q.xyz / q.w;
    vec2 uv = ndc.xy * 0.5 + 0.5;  // in the light's tile
    float depth = ndc.z * 0.5 + 0.5 - shadow_depth_bias;
    vec2 tile = vec2(i % shadow_tiles, i / shadow_tiles);
    float inv = 1.0 / float(shadow_tiles);
    float v = 0.0;
    for (int k = 0; k < 4; ++k) {
        vec2 o = (vec2(k & 1, k >> 1) - 0.5) / shadow_size;
        vec2 t = clamp(uv + o, 0.5 / shadow_size, 1.0 - 0.5 / shadow_size);  // stay in the tile
        v += textureLod(shadow_atlas, vec3((tile + t) * inv, depth), 0.0);  // no mips: no derivatives needed
    }
    return 0.25 * v;
}
#endif
