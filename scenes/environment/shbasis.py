"""The real SH basis on world (x, y, z) directions: the paper's SH9 (docs/contract.md section 3, eq. 8)
and its extension to orders 3..8 (16..81 coefficients; `sh_order` uses 3 and 4, PRT up to 8).

Order: Y00, Y1-1, Y10, Y11, Y2-2, Y2-1, Y20, Y21, Y22 (Ramamoorthi & Hanrahan 2001, eq. 3):
    Y00 = 0.282095;  Y1-1 = 0.488603 y;  Y10 = 0.488603 z;  Y11 = 0.488603 x;
    Y2-2 = 1.092548 xy;  Y2-1 = 1.092548 yz;  Y21 = 1.092548 xz;
    Y20 = 0.315392 (3 z^2 - 1);  Y22 = 0.546274 (x^2 - y^2).
Both renderers (and the GLSL projection shader) use exactly these constants.

Higher bands continue the same convention: coefficient k = l^2 + l + m (band l, then m = -l..l), the
"z-up" textbook functions applied to world (x, y, z) as given (Y_l0 depends on z only), and no
Condon-Shortley phase (Y11 = +0.488603 x, as above). With z = cos(theta), x + i y = sin(theta) e^(i phi):

    Y_l0  = N_l0 P_l(z)
    Y_lm  = N_lm Re((x + i y)^m) P_l^(m)(z),   Y_l-m = N_lm Im((x + i y)^m) P_l^(m)(z)   (m > 0)
    N_lm  = sqrt((2l + 1) / (4 pi) (l - m)! / (l + m)!) (times sqrt(2) when m > 0)

where P_l^(m) is the m-th derivative of the Legendre polynomial P_l (so that sin^m(theta) P_l^(m) is the
associated Legendre function without the (-1)^m phase). The normalisation is the standard one (e.g.
Sloan 2008, "Stupid spherical harmonics (SH) tricks", appendix; Filament's CubemapSH uses the same
polynomials). The constants of bands 3 and 4 are computed from it below in float64; bands 0-2 keep the
paper's 6-digit literals, so `sh_basis(d, 2)` is `sh9(d)` bit for bit.

Bands 5..8 are evaluated generically (numpy here, GLSL in sh_basis.glsl, the same arithmetic): per (l, m)
the polynomial N_lm P_l^(m)(z), stored as float64 coefficients in z^2 (times z when l - m is odd, the
parity of P_l^(m)), evaluated by Horner's rule, times Re / Im (x + iy)^m built by the complex
recurrence (x + iy)^m = (x + iy)^(m-1) (x + iy).
"""

from __future__ import annotations

import math

import numpy as np

C0, C1, C2, C3, C4 = 0.282095, 0.488603, 1.092548, 0.315392, 0.546274
#: the band l of each of the nine coefficients
BAND = np.array([0, 1, 1, 1, 2, 2, 2, 2, 2])
#: the highest supported order (band)
MAX_ORDER = 8
#: the first band evaluated by the generic polynomial tables (bands 0..4 have their own literals)
FIRST_GENERIC_BAND = 5


def _cosine_band_factor(l: int) -> float:
    """A_l = 2 pi int_0^1 P_l(t) t dt for l >= 2 (Ramamoorthi & Hanrahan 2001, "An efficient representation
    for irradiance environment maps", eq. 8 with A_l = sqrt(4 pi / (2l + 1)) hat-A_l):
        A_l = 0 for odd l > 1;
        A_l = 2 pi (-1)^(l/2 - 1) / ((l + 2)(l - 1)) * l! / (2^l ((l/2)!)^2) for even l
    which gives pi/4, -pi/24, pi/64, -pi/128 for l = 2, 4, 6, 8."""
    if l % 2:
        return 0.0
    half = l // 2
    return (2 * math.pi * (-1) ** (half - 1) / ((l + 2) * (l - 1))
            * math.factorial(l) / (2**l * math.factorial(half) ** 2))


#: Ramamoorthi & Hanrahan 2001 (eq. 8-9): the clamped cosine max(cos, 0) has zonal factors
#: A_l = 2 pi int_0^1 P_l(t) t dt = pi, 2pi/3, pi/4, 0, -pi/24 for l = 0..4 (these literals), and for
#: l = 5..8 the closed form of `_cosine_band_factor` (0, pi/64, 0, -pi/128)
COSINE_BAND_FACTORS = np.array([np.pi, 2 * np.pi / 3, np.pi / 4, 0.0, -np.pi / 24]
                               + [_cosine_band_factor(l) for l in range(FIRST_GENERIC_BAND, MAX_ORDER + 1)])


def _norm(l: int, m: int) -> float:
    """N_lm of the module docstring (m >= 0)."""
    n = math.sqrt((2 * l + 1) / (4 * math.pi) * math.factorial(l - m) / math.factorial(l + m))
    return n * math.sqrt(2.0) if m else n


# Each constant multiplies the integer-coefficient polynomial written beside it; the rational factor
# is the leading factor of P_l^(m):
#   P_3 = (5z^3 - 3z) / 2, P_3' = 3/2 (5z^2 - 1), P_3'' = 15 z, P_3''' = 15;
#   P_4 = (35z^4 - 30z^2 + 3) / 8, P_4' = 5/2 (7z^3 - 3z), P_4'' = 15/2 (7z^2 - 1), P_4''' = 105 z, P_4'''' = 105;
#   Re/Im (x + iy)^2 = x^2 - y^2, 2xy;  (x + iy)^3 = x (x^2 - 3y^2), y (3x^2 - y^2);
#   (x + iy)^4 = x^4 - 6x^2y^2 + y^4, 4xy (x^2 - y^2).
K30 = _norm(3, 0) / 2  # z (5z^2 - 3)                              = 0.3731763
K31 = _norm(3, 1) * 3 / 2  # (x | y) (5z^2 - 1)                    = 0.4570458
K32 = _norm(3, 2) * 15  # z (x^2 - y^2 | 2xy)                      = 1.445306
K33 = _norm(3, 3) * 15  # x (x^2 - 3y^2) | y (3x^2 - y^2)          = 0.5900436
K40 = _norm(4, 0) / 8  # 35z^4 - 30z^2 + 3                         = 0.1057855
K41 = _norm(4, 1) * 5 / 2  # (x | y) z (7z^2 - 3)                  = 0.6690465
K42 = _norm(4, 2) * 15 / 2  # (x^2 - y^2 | 2xy) (7z^2 - 1)         = 0.4730873
K43 = _norm(4, 3) * 105  # z (x (x^2 - 3y^2) | y (3x^2 - y^2))     = 1.770131
K44 = _norm(4, 4) * 105  # x^4 - 6x^2y^2 + y^4 | 4xy (x^2 - y^2)   = 0.6258357

def _legendre_derivative(l: int, m: int) -> np.ndarray:
    """Coefficients (increasing powers of z, float64) of P_l^(m)(z), the m-th derivative of P_l, from the
    associated Legendre recurrence without the sin^m(theta) factor and the (-1)^m phase (Abramowitz &
    Stegun 8.5.3, which holds for the derivatives alike):
        P_m^(m) = (2m - 1)!!,   P_(m-1)^(m) = 0,
        (l - m) P_l^(m) = (2l - 1) z P_(l-1)^(m) - (l + m - 1) P_(l-2)^(m).
    The coefficients are dyadic rationals: exact in float64 for these bands."""
    prev = np.zeros(l + 1)  # P_(m-1)^(m) = 0
    cur = np.zeros(l + 1)
    cur[0] = float(math.prod(range(1, 2 * m, 2)))  # (2m - 1)!!
    for n in range(m + 1, l + 1):
        nxt = np.zeros(l + 1)
        nxt[1:] = (2 * n - 1) * cur[:-1]  # (2n - 1) z P_(n-1)^(m)
        nxt -= (n + m - 1) * prev
        prev, cur = cur, nxt / (n - m)
    return cur


def _generic_polynomial(l: int, m: int) -> np.ndarray:
    """N_lm P_l^(m)(z) as coefficients in z^2 (increasing powers); the polynomial is z^((l - m) mod 2) times it."""
    return _norm(l, m) * _legendre_derivative(l, m)[(l - m) % 2 : l - m + 1 : 2]


#: per band l >= FIRST_GENERIC_BAND, the z^2-coefficients of N_lm P_l^(m) for m = 0..l, concatenated (m
#: ascending, each (l - m) // 2 + 1 values): the table sh_basis and sh_basis.glsl walk
GENERIC_POLYNOMIALS: dict[int, np.ndarray] = {
    l: np.concatenate([_generic_polynomial(l, m) for m in range(l + 1)])
    for l in range(FIRST_GENERIC_BAND, MAX_ORDER + 1)
}


def _generic_bands(x: np.ndarray, y: np.ndarray, z: np.ndarray, order: int) -> list[np.ndarray]:
    """Bands FIRST_GENERIC_BAND..order, each (..., 2l + 1), in sh_basis.glsl's arithmetic."""
    z2 = z * z
    re, im = [np.ones_like(x)], [np.zeros_like(x)]
    for _ in range(order):  # (x + iy)^m = (x + iy)^(m-1) (x + iy)
        re.append(re[-1] * x - im[-1] * y)
        im.append(re[-2] * y + im[-1] * x)
    out = []
    for l in range(FIRST_GENERIC_BAND, order + 1):
        table, p = GENERIC_POLYNOMIALS[l], 0
        band = [None] * (2 * l + 1)
        for m in range(l + 1):
            n = (l - m) // 2 + 1
            q = np.zeros_like(z)
            for j in range(n - 1, -1, -1):  # Horner in z^2
                q = q * z2 + table[p + j]
            p += n
            if (l - m) % 2:
                q = q * z
            if m == 0:
                band[l] = q
            else:
                band[l + m], band[l - m] = q * re[m], q * im[m]
        out.append(np.stack(band, axis=-1))
    return out


#: GLSL names and values of the constants per band (bands 0-2: the exact literals of sh_project.comp)
_GLSL_CONSTANTS: dict[int, tuple[tuple[str, str], ...]] = {
    0: (("SH_C0", "0.282095"),),
    1: (("SH_C1", "0.488603"),),
    2: (("SH_C2", "1.092548"), ("SH_C3", "0.315392"), ("SH_C4", "0.546274")),
}


def _glsl_float(v: float) -> str:
    """A float literal GLSL reads back to the same float32 (9 significant digits, always a float)."""
    s = f"{v:.9g}"
    return s if any(c in s for c in ".en") else s + ".0"


_GLSL_CONSTANTS[3] = tuple((f"SH_K3{m}", _glsl_float(k)) for m, k in enumerate((K30, K31, K32, K33)))
_GLSL_CONSTANTS[4] = tuple((f"SH_K4{m}", _glsl_float(k)) for m, k in enumerate((K40, K41, K42, K43, K44)))


def count(order: int) -> int:
    """Number of coefficients of bands 0..order: (order + 1)^2."""
    return (order + 1) ** 2


def order_of(n_coeffs: int) -> int:
    """The order whose coefficient count is n_coeffs (9 -> 2, 16 -> 3, 25 -> 4)."""
    order = math.isqrt(n_coeffs) - 1
    if order < 0 or count(order) != n_coeffs or order > MAX_ORDER:
        raise ValueError(f"{n_coeffs} is not an SH coefficient count ((order + 1)^2, order 0..{MAX_ORDER})")
    return order


def band_of(order: int) -> np.ndarray:
    """The band l of each of the (order + 1)^2 coefficients: [0, 1, 1, 1, 2, ...]."""
    return np.repeat(np.arange(order + 1), 2 * np.arange(order + 1) + 1)


def sh9(d: np.ndarray) -> np.ndarray:
    """Basis values (..., 9) at unit directions d (..., 3)."""
    d = np.asarray(d, dtype=np.float64)
    x, y, z = d[..., 0], d[..., 1], d[..., 2]
    return np.stack([
        np.full_like(x, C0), C1 * y, C1 * z, C1 * x,
        C2 * x * y, C2 * y * z, C3 * (3 * z * z - 1), C2 * x * z, C4 * (x * x - y * y),
    ], axis=-1)


def sh_basis(d: np.ndarray, order: int) -> np.ndarray:
    """Basis values (..., (order + 1)^2) at unit directions d (..., 3), bands 0..order (order <= MAX_ORDER)."""
    if not 0 <= order <= MAX_ORDER:
        raise ValueError(f"SH order must be 0..{MAX_ORDER}, got {order}")
    y9 = sh9(d)
    if order <= 2:
        return y9[..., : count(order)]
    d = np.asarray(d, dtype=np.float64)
    x, y, z = d[..., 0], d[..., 1], d[..., 2]
    z2 = z * z
    re2, im2 = x * x - y * y, 2 * x * y  # Re, Im of (x + iy)^2
    re3, im3 = x * (x * x - 3 * y * y), y * (3 * x * x - y * y)
    a31 = K31 * (5 * z2 - 1)
    band3 = [K33 * im3, K32 * z * im2, a31 * y, K30 * z * (5 * z2 - 3), a31 * x, K32 * z * re2, K33 * re3]
    out = [y9, np.stack(band3, axis=-1)]
    if order >= 4:
        a41 = K41 * z * (7 * z2 - 3)
        a42 = K42 * (7 * z2 - 1)
        re4, im4 = re2 * re2 - im2 * im2, 2 * re2 * im2  # (x + iy)^4 = ((x + iy)^2)^2
        band4 = [K44 * im4, K43 * z * im3, a42 * im2, a41 * y, K40 * ((35 * z2 - 30) * z2 + 3),
                 a41 * x, a42 * re2, K43 * z * re3, K44 * re4]
        out.append(np.stack(band4, axis=-1))
    if order >= FIRST_GENERIC_BAND:
        out += _generic_bands(x, y, z, order)
    return np.concatenate(out, axis=-1)


def glsl_defines(order: int) -> tuple[str, ...]:
    """`#define` bodies ("NAME VALUE") that realtime/shaders/sh_basis.glsl and sh_*_n.comp need.

    SH_ORDER, SH_COUNT, the basis constants of bands 0..order (SH_C0..SH_C4 for bands 0-2, the
    paper's literals; SH_K3m for m = 0..3, SH_K4m for m = 0..4, each multiplying the polynomial
    named beside K3m / K4m above; for order >= 5 SH_POLY, the GENERIC_POLYNOMIALS of bands 5..order
    concatenated as a GLSL float[] constructor), and the clamped-cosine factors SH_A0..SH_A<order>.
    """
    if not 2 <= order <= MAX_ORDER:
        raise ValueError(f"the GLSL SH evaluation supports orders 2..{MAX_ORDER}, got {order}")
    out = [f"SH_ORDER {order}", f"SH_COUNT {count(order)}"]
    for band in range(min(order, FIRST_GENERIC_BAND - 1) + 1):
        out += [f"{name} {value}" for name, value in _GLSL_CONSTANTS[band]]
    if order >= FIRST_GENERIC_BAND:
        table = np.concatenate([GENERIC_POLYNOMIALS[l] for l in range(FIRST_GENERIC_BAND, order + 1)])
        out.append(f"SH_POLY float[]({', '.join(_glsl_float(v) for v in table)})")
    out += [f"SH_A{band} {_glsl_float(COSINE_BAND_FACTORS[band])}" for band in range(order + 1)]
    return tuple(out)
