#version 430
// The per-vertex sum of the wavelet transfer (Ng, Ramamoorthi & Hanrahan 2003, section 6): E = sum over the K kept
// lighting coefficients l_j (wavelet_select.comp) of l_j w_v[j], w_v the vertex's stored (index, value) pairs
// (sorted by index, wavelet_transfer.py). Two exact ways to the same terms, summed in the same (increasing index)
// order, so the same float result; each vertex takes the cheaper for its own nnz:
//   search: for each kept index (in increasing order) a binary search among the vertex's entries, starting where
//           the previous one ended: K x log2(nnz) reads (Ng et al.'s cost model, best for small K);
//   scan:   each stored entry reads the dense selected lighting (zeros except the K kept): nnz reads.
// Cost per vertex: min(K (floor(log2(nnz)) + 2), nnz) reads, the search's count bounded from above.
// CHANNELS (1 or 3): values per stored entry (3 when bounces make the transfer depend on the colour).
layout(local_size_x = 64) in;
layout(std430, binding = 2) readonly buffer Dense { vec4 dense[]; };  // N: the kept coefficients, zeros elsewhere
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
    uint nnz = hi - lo;
    uint search_reads = uint(k) * (uint(findMSB(max(nnz, 1u))) + 2u);
    if (nnz <= search_reads) {
        for (uint a = lo; a < hi; ++a) {
#if CHANNELS == 3
            vec3 w = vec3(values[3u * a], values[3u * a + 1u], values[3u * a + 2u]);
#else
            vec3 w = vec3(values[a]);
#endif
            E += dense[indices[a]].rgb * w;
        }
        irradiance[v] = vec4(E, 0.0);
        return;
    }
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
