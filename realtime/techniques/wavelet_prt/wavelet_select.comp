#version 430
// The non-linear lighting approximation (Ng, Ramamoorthi & Hanrahan 2003, section 5): keep the K coefficients
// of largest selection key (wavelet_haar.comp's alpha), exactly K, ties to the smaller flat index (haar.py).
// One workgroup: the keys are non-negative floats, whose bit patterns order as unsigned integers, so the K-th
// largest key tau is found bit by bit (31 counting rounds: the largest u with #{key >= u} >= K); then the
// need = K - #{key > tau} ties with the smallest indices are kept: the need-th tie's index is found the same
// way (INDEX_BITS rounds of #{key == tau, index < m}). Each round counts over all N keys, every invocation a
// strided share, summed with a shared atomic counter. Then the kept coefficients are written in index order
// (each invocation compacts its contiguous range at an offset from an exclusive scan of the ranges' counts)
// and as a dense buffer (zeros except the K kept; alpha 1 where kept).
layout(local_size_x = 256) in;
layout(std430, binding = 1) readonly buffer Coefficients { vec4 coeff[]; };
layout(std430, binding = 2) writeonly buffer Dense { vec4 dense[]; };
layout(std430, binding = 3) writeonly buffer KeptIndex { uint kept_index[]; };
layout(std430, binding = 4) writeonly buffer KeptValue { vec4 kept_value[]; };
uniform int n;  // coefficients: 6 s^2
uniform int k;  // kept: 1 <= K <= n
uniform int index_bits;  // 2^index_bits >= n

shared uint total;
shared uint offsets[256];

uint bits_of(int i) {
    return floatBitsToUint(coeff[i].a);
}

// #{i : key bits >= t} (mode 0), or #{i : key bits == t and i < m} (mode 1); uniform control flow
uint count_keys(int mode, uint t, uint m) {
    uint c = 0u;
    for (int i = int(gl_LocalInvocationIndex); i < n; i += 256) {
        uint b = bits_of(i);
        c += (mode == 0) ? uint(b >= t) : uint(b == t && uint(i) < m);
    }
    barrier();
    if (gl_LocalInvocationIndex == 0u) total = 0u;
    barrier();
    atomicAdd(total, c);
    barrier();
    uint result = total;
    barrier();
    return result;
}

void main() {
    uint K = uint(k);
    uint tau = 0u;
    for (int bit = 30; bit >= 0; --bit) {  // bit 31 (the sign) is 0 for every key
        uint candidate = tau | (1u << uint(bit));
        if (count_keys(0, candidate, 0u) >= K) tau = candidate;
    }
    uint greater = (tau == 0xFFFFFFFFu) ? 0u : count_keys(0, tau + 1u, 0u);
    uint need = K - greater;  // >= 1 ties at tau are kept
    uint last = 0u;  // the index of the need-th tie: #{ties below last} < need
    for (int bit = index_bits - 1; bit >= 0; --bit) {
        uint candidate = last | (1u << uint(bit));
        if (count_keys(1, tau, candidate) < need) last = candidate;
    }
    uint lid = gl_LocalInvocationIndex;
    int chunk = (n + 255) / 256;
    int lo = min(n, int(lid) * chunk), hi = min(n, lo + chunk);
    uint mine = 0u;
    for (int i = lo; i < hi; ++i) {
        uint b = bits_of(i);
        bool keep = b > tau || (b == tau && uint(i) <= last);
        mine += uint(keep);
        dense[i] = keep ? vec4(coeff[i].rgb, 1.0) : vec4(0.0);
    }
    offsets[lid] = mine;
    barrier();
    if (lid == 0u) {
        uint run = 0u;
        for (int j = 0; j < 256; ++j) {
            uint c = offsets[j];
            offsets[j] = run;
            run += c;
        }
    }
    barrier();
    uint at = offsets[lid];
    for (int i = lo; i < hi; ++i) {
        uint b = bits_of(i);
        if (b > tau || (b == tau && uint(i) <= last)) {
            kept_index[at] = uint(i);
            kept_value[at] = vec4(coeff[i].rgb, 0.0);
            ++at;
        }
    }
}
