#version 430
// The per-vertex sum of the wavelet transfer (Ng, Ramamoorthi & Hanrahan 2003, section 6): for each of the K kept
// lighting coefficients (wavelet_select.comp, in increasing index order) a binary search for its index among the
// vertex's stored (index, value) pairs (sorted by index, wavelet_transfer.py); where found, E += l_j w_v[j]. The
// search starts where the previous one ended (the kept indices increase): cost V x K x log2(nnz) reads.
// CHANNELS (1 or 3): values per stored entry (3 when bounces make the transfer depend on the colour).
layout(local_size_x = 64) in;
layout(std430, binding = 3) readonly buffer KeptIndex { uint kept_index[]; };
layout(std430, binding = 4) readonly buffer KeptValue { vec4 kept_value[]; };
layout(std430, binding = 5) readonly buffer Offsets { uint offsets[]; };  // V + 1
layout(std430, binding = 6) readonly buffer Indices { uint indices[]; };
layout(std430, binding = 7) readonly buffer Values { float values[]; };  // nnz x CHANNELS
layout(std430, binding = 8) writeonly buffer Irradiance { vec4 irradiance[]; };  // V
uniform int vertices;
uniform int k;

void main() {
    int v = int(gl_GlobalInvocationID.x);
    if (v >= vertices) return;
    uint lo = offsets[v], hi = offsets[v + 1];
    vec3 E = vec3(0.0);
    for (int j = 0; j < k && lo < hi; ++j) {
        uint target = kept_index[j];
        uint a = lo, b = hi;
        while (a < b) {  // lower bound of target in indices[lo, hi)
            uint m = (a + b) >> 1;
            if (indices[m] < target) a = m + 1u; else b = m;
        }
        if (a < hi && indices[a] == target) {
#if CHANNELS == 3
            vec3 w = vec3(values[3u * a], values[3u * a + 1u], values[3u * a + 2u]);
#else
            vec3 w = vec3(values[a]);
#endif
            E += kept_value[j].rgb * w;
        }
        lo = a;
    }
    irradiance[v] = vec4(E, 0.0);
}
