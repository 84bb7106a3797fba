#version 430
// One level of the orthonormal non-standard 2D Haar transform of the lighting cube (haar.py), computed from the
// engine's 2x2 box chain: the block (p, q) of a level with h blocks per face side has as its four quadrant means
// a, b, c, d the four texels of the 2h x 2h box level under it (rows 2p, 2p + 1; columns 2q, 2q + 1), and its
// orthonormal coefficients are s / (4 h) times
//     horizontal (a - b + c - d) at [p, h + q],  vertical (a + b - c - d) at [h + p, q],
//     diagonal (a - b - c + d) at [h + p, h + q],
// with, at h = 1, the scaling coefficient s / 4 (a + b + c + d) = s x the face's mean at [0, 0]. The alpha of
// each coefficient is its selection key: the fraction of the face its support covers (1 / h^2, the scaling
// coefficient 1) times |r| + |g| + |b| (Ng, Ramamoorthi & Hanrahan 2003, section 5).
layout(local_size_x = 8, local_size_y = 8, local_size_z = 1) in;
layout(rgba32f, binding = 0) uniform readonly imageCube children;  // the box level of face side 2h
uniform int size;  // s, the lighting's face side (realtime.wavelet_prt.cube_size)
uniform int h;  // blocks per face side of this level: 1, 2, ..., s / 2
layout(std430, binding = 1) writeonly buffer Coefficients { vec4 coeff[]; };  // (6, s, s): rgb, key

float key(vec3 c, float area) {
    return area * (abs(c.r) + abs(c.g) + abs(c.b));
}

void main() {
    ivec3 g = ivec3(gl_GlobalInvocationID);  // (q: column, p: row, face)
    if (g.x >= h || g.y >= h) return;
    int q = g.x, p = g.y, f = g.z;
    vec3 a = imageLoad(children, ivec3(2 * q, 2 * p, f)).rgb;
    vec3 b = imageLoad(children, ivec3(2 * q + 1, 2 * p, f)).rgb;
    vec3 c = imageLoad(children, ivec3(2 * q, 2 * p + 1, f)).rgb;
    vec3 d = imageLoad(children, ivec3(2 * q + 1, 2 * p + 1, f)).rgb;
    float scale = float(size) / float(4 * h);
    float area = 1.0 / float(h * h);
    int base = f * size * size;
    vec3 horizontal = scale * (a - b + c - d);
    vec3 vertical = scale * (a + b - c - d);
    vec3 diagonal = scale * (a - b - c + d);
    coeff[base + p * size + h + q] = vec4(horizontal, key(horizontal, area));
    coeff[base + (h + p) * size + q] = vec4(vertical, key(vertical, area));
    coeff[base + (h + p) * size + h + q] = vec4(diagonal, key(diagonal, area));
    if (h == 1) {
        vec3 scaling = scale * (a + b + c + d);
        coeff[base] = vec4(scaling, key(scaling, 1.0));
    }
}
