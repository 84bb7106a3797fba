#version 430
// The light array's powers, every frame (realtime/techniques/lights/lights.py, scenes/environment/light_array.py): light i carries
// sum over the texels of its region of L(texel) dOmega(row), the environment's radiance integrated
// over its spherical Voronoi cell (geodesic) or median-cut rectangle, so the powers sum to the map's
// integral. One work group per light: its threads stride over the light's texel list, then a tree
// reduction in shared memory.
layout(local_size_x = 64) in;
uniform sampler2D env;  // the equirect map (H, W), row 0 = +Y; NEAREST
layout(std430, binding = 1) readonly buffer Offsets { int offsets[]; };   // light i: texels[offsets[i] .. offsets[i+1])
layout(std430, binding = 2) readonly buffer Texels { int texels[]; };     // row * W + col, grouped by light
layout(std430, binding = 3) readonly buffer RowOmega { float row_omega[]; };  // dOmega of a texel of each row
layout(std430, binding = 4) writeonly buffer Powers { vec4 powers[]; };
uniform int width;
shared vec3 partial[64];

void main() {
    int light = int(gl_WorkGroupID.x);
    int t = int(gl_LocalInvocationID.x);
    vec3 sum = vec3(0.0);
    for (int k = offsets[light] + t; k < offsets[light + 1]; k += 64) {
        int texel = texels[k];
        int row = texel / width;
        sum += texelFetch(env, ivec2(texel - row * width, row), 0).rgb * row_omega[row];
    }
    partial[t] = sum;
    barrier();
    for (int stride = 32; stride > 0; stride >>= 1) {
        if (t < stride) partial[t] += partial[t + stride];
        barrier();
    }
    if (t == 0) powers[light] = vec4(partial[0], 0.0);
}
