"""SH projection (the paper's SH9, and orders 3-4) and the irradiance matrices M of the paper
(numpy reference implementation).

Projection (docs/contract.md section 3, step 3): L_lm = sum over texels of L(w) Y_lm(w) dOmega(w), with
exact texel solid angles (cube faces: `scenes.environment.cubemap.texel_solid_angles`; equirect maps:
`scenes.environment.directions.equirect_solid_angles`). `order` 2 (default) is the paper's 9 coefficients; 3 and 4
give 16 and 25 (docs/contract.md section 9, `sh_order`; basis: `scenes.environment.shbasis.sh_basis`).

Irradiance (Ramamoorthi & Hanrahan 2001, "An efficient representation for irradiance environment
maps", eq. 12): E(n) = n^T M n with n = (x, y, z, 1) and, per colour channel,

    M = [[c1 L22,  c1 L2-2, c1 L21,  c2 L11],
         [c1 L2-2, -c1 L22, c1 L2-1, c2 L1-1],
         [c1 L21,  c1 L2-1, c3 L20,  c2 L10],
         [c2 L11,  c2 L1-1, c2 L10,  c4 L00 - c5 L20]]

c1 = 0.429043, c2 = 0.511664, c3 = 0.743125, c4 = 0.886227, c5 = 0.247708. (The seed paper prints
c5 = 0.429043; that is a typo: c5 = c3 / 3, which makes a constant environment of radiance 1 give
E = pi.) The GPU path (shaders sh_project.comp, sh_reduce.comp) computes the same quantities and is
tested against this module.

Any order: E(n) = sum_lm A_l L_lm Y_lm(n) with A_l = `COSINE_BAND_FACTORS` (pi, 2pi/3, pi/4, 0, -pi/24;
R&H 2001 eq. 8-9). A_3 = 0: order 3 gives exactly the irradiance of order 2.
"""

from __future__ import annotations

import numpy as np

from scenes.environment import cubemap
from scenes.environment.directions import equirect_directions, equirect_solid_angles, rotation_y, uv_to_direction
from scenes.environment.shbasis import COSINE_BAND_FACTORS, band_of, order_of, sh9, sh_basis

C1, C2, C3, C4, C5 = 0.429043, 0.511664, 0.743125, 0.886227, 0.247708


def _basis(d: np.ndarray, order: int) -> np.ndarray:
    # order 2 goes through the module-level sh9 (tests substitute it to evaluate in another frame)
    return sh9(d) if order == 2 else sh_basis(d, order)


def project_cube(faces: np.ndarray, order: int = 2) -> np.ndarray:
    """SH coefficients ((order + 1)^2, 3) of cube faces (6, s, s, 3 or 4) with exact texel solid angles."""
    faces = np.asarray(faces, dtype=np.float64)[..., :3]
    size = faces.shape[1]
    d = cubemap.texel_directions(size)
    w = np.broadcast_to(cubemap.texel_solid_angles(size), (6, size, size))
    return np.einsum("fijk,fij,fijc->kc", _basis(d, order), w, faces)


def project_equirect(env: np.ndarray, rotation_deg: float = 0.0, rows: str = "mitsuba", order: int = 2) -> np.ndarray:
    """SH coefficients ((order + 1)^2, 3) of an equirect map (order 2: the paper's SH9).

    rows="mitsuba" (default): the map as Mitsuba and both renderers see it, row r at polar angle
    pi r / (H - 1) (align-corners), weights = exact band areas.
    rows="centre": row r at pi (r + 0.5) / H, weights sin(theta) dtheta dphi: the convention most
    probe files (and Ramamoorthi & Hanrahan's published coefficients) were made with. The two
    differ where the map is bright near a pole: Mitsuba's reading moves the top and bottom rows
    half a pixel towards the poles, where they cover less solid angle (Uffizi: 3 % of L1-1).
    With `rotation_deg`, the coefficients are those of the map turned about +Y (world frame).
    """
    env = np.asarray(env, dtype=np.float64)
    h, w = env.shape[:2]
    if rows == "mitsuba":
        d = equirect_directions(h, w)
        weights = equirect_solid_angles(h, w)
    elif rows == "centre":
        v = (np.arange(h) + 0.5) / h
        d = uv_to_direction(((np.arange(w) + 0.5) / w)[None, :], v[:, None])
        weights = np.repeat((np.sin(np.pi * v) * (np.pi / h) * (2 * np.pi / w))[:, None], w, axis=1)
    else:
        raise ValueError(f"rows must be 'mitsuba' or 'centre', got {rows!r}")
    if rotation_deg:
        d = d @ rotation_y(rotation_deg).T  # the map's sample directions, placed in the world
    return np.einsum("ijk,ij,ijc->kc", _basis(d, order), weights, env)


def irradiance_matrices(coeffs: np.ndarray) -> np.ndarray:
    """The paper's M (eq. 12), one 4x4 symmetric matrix per colour channel: (3, 4, 4)."""
    L = np.asarray(coeffs, dtype=np.float64)
    L00, L1m1, L10, L11, L2m2, L2m1, L20, L21, L22 = (L[i] for i in range(9))
    M = np.stack([
        np.stack([C1 * L22, C1 * L2m2, C1 * L21, C2 * L11], -1),
        np.stack([C1 * L2m2, -C1 * L22, C1 * L2m1, C2 * L1m1], -1),
        np.stack([C1 * L21, C1 * L2m1, C3 * L20, C2 * L10], -1),
        np.stack([C2 * L11, C2 * L1m1, C2 * L10, C4 * L00 - C5 * L20], -1),
    ], -2)  # rows of (3, 4) stacked at axis -2: (channel, row, column)
    return M


def irradiance(M: np.ndarray, normals: np.ndarray) -> np.ndarray:
    """E(n) = n^T M n per channel: (..., 3) for unit normals (..., 3)."""
    n = np.asarray(normals, dtype=np.float64)
    n4 = np.concatenate([n, np.ones(n.shape[:-1] + (1,))], axis=-1)
    return np.einsum("...i,cij,...j->...c", n4, M, n4)


def irradiance_from_sh(coeffs: np.ndarray, normals: np.ndarray) -> np.ndarray:
    """E(n) = sum_lm A_l L_lm Y_lm(n), the direct SH sum (A_0 = pi, A_1 = 2pi/3, A_2 = pi/4, A_3 = 0,
    A_4 = -pi/24); the order follows from the coefficient count (9, 16 or 25)."""
    coeffs = np.asarray(coeffs, dtype=np.float64)
    order = order_of(len(coeffs))
    a = COSINE_BAND_FACTORS[band_of(order)]
    return np.einsum("...k,k,kc->...c", _basis(normals, order), a, coeffs)


def band_energy(coeffs: np.ndarray) -> np.ndarray:
    """Energy per band l = 0..order (sum of squared coefficients), per channel: (order + 1, C)."""
    c2 = np.asarray(coeffs, dtype=np.float64) ** 2
    band = band_of(order_of(len(c2)))
    return np.stack([c2[band == b].sum(axis=0) for b in range(band[-1] + 1)])
