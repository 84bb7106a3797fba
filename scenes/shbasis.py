"""The real SH9 basis on world (x, y, z) directions (design.md section 3, the paper's eq. 8).

Order: Y00, Y1-1, Y10, Y11, Y2-2, Y2-1, Y20, Y21, Y22 (Ramamoorthi & Hanrahan 2001, eq. 3):
    Y00 = 0.282095;  Y1-1 = 0.488603 y;  Y10 = 0.488603 z;  Y11 = 0.488603 x;
    Y2-2 = 1.092548 xy;  Y2-1 = 1.092548 yz;  Y21 = 1.092548 xz;
    Y20 = 0.315392 (3 z^2 - 1);  Y22 = 0.546274 (x^2 - y^2).
Both renderers (and the GLSL projection shader) use exactly these constants.
"""

from __future__ import annotations

import numpy as np

C0, C1, C2, C3, C4 = 0.282095, 0.488603, 1.092548, 0.315392, 0.546274
#: the band l of each of the nine coefficients
BAND = np.array([0, 1, 1, 1, 2, 2, 2, 2, 2])


def sh9(d: np.ndarray) -> np.ndarray:
    """Basis values (..., 9) at unit directions d (..., 3)."""
    d = np.asarray(d, dtype=np.float64)
    x, y, z = d[..., 0], d[..., 1], d[..., 2]
    return np.stack([
        np.full_like(x, C0), C1 * y, C1 * z, C1 * x,
        C2 * x * y, C2 * y * z, C3 * (3 * z * z - 1), C2 * x * z, C4 * (x * x - y * y),
    ], axis=-1)
