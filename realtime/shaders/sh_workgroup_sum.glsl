// Workgroup sum of each of the 64 invocations' SH_COUNT RGB values, for the SH projection passes
// (sh_project_n.comp, map_sh_project.comp, sh_reduce_n.comp): SH_CHUNK coefficients at a time through
// shared memory, so that 64 x SH_CHUNK vec3 (padded to 16 bytes: 25.6 KiB) stays under the 32 KiB that
// GL guarantees for GL_MAX_COMPUTE_SHARED_MEMORY_SIZE; all 81 coefficients of order 8 at once would need
// 83 KiB. Orders 2..4 (<= 25 coefficients) are one chunk, the former single tree reduction.
// On return invocation 0's c[] holds the workgroup's sums. Call it in uniform control flow.
#define SH_CHUNK 25

shared vec3 sh_acc[64][SH_CHUNK];

void sh_workgroup_sum(uint lid, inout vec3 c[SH_COUNT]) {
    for (int k0 = 0; k0 < SH_COUNT; k0 += SH_CHUNK) {
        int n = min(SH_CHUNK, SH_COUNT - k0);
        for (int j = 0; j < n; ++j) sh_acc[lid][j] = c[k0 + j];
        barrier();
        for (uint stride = 32u; stride > 0u; stride >>= 1u) {
            if (lid < stride)
                for (int j = 0; j < n; ++j) sh_acc[lid][j] += sh_acc[lid + stride][j];
            barrier();
        }
        if (lid == 0u)
            for (int j = 0; j < n; ++j) c[k0 + j] = sh_acc[0][j];
        barrier();  // the next chunk overwrites sh_acc
    }
}
