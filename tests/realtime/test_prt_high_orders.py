"""PRT at SH orders up to 8 (prt_transfer.py), against expectations computed here without the SH basis:
for a zonal environment L(w) = exp(kappa (w.mu - 1)) the order-N SH irradiance is, by Funk-Hecke twice,
    E_N(n) = sum_{l <= N} A_l lambda_l (2l + 1) / (4 pi) P_l(n.mu),   lambda_l = 2 pi int_{-1}^1 L(t) P_l(t) dt,
    A_l = 2 pi int_0^1 P_l(t) t dt,
both integrals by Gauss-Legendre in this file; the exact irradiance E(n) = int_{n.w > 0} L(w) (n.w) dw by a
Gauss-Legendre x phi rule over the hemisphere about n (smooth there: no kink). A convex sphere's transfer at
order N dotted with L's coefficients must be E_N at its vertices, shadowed or not, and approach E as N grows."""

from __future__ import annotations

import time

import numpy as np
import pytest
from numpy.polynomial import legendre

import scenes
from realtime.techniques.prt.prt import transfer_objects
from realtime.techniques.prt.prt_transfer import check_memory, memory_limit, transfer, transfer_bytes, transfer_key
from scenes.environment.shbasis import sh_basis

KAPPA = 20.0
MU = np.array([0.48, -0.6, 0.64])


def lobe(d: np.ndarray) -> np.ndarray:
    return np.exp(KAPPA * (d @ MU - 1.0))


def gl01(n: int) -> tuple[np.ndarray, np.ndarray]:
    x, w = legendre.leggauss(n)
    return (x + 1) / 2, w / 2


def lambda_l(l: int) -> float:
    t, w = legendre.leggauss(80)
    return float(2 * np.pi * np.sum(w * np.exp(KAPPA * (t - 1)) * legendre.legval(t, np.eye(l + 1)[l])))


def a_l(l: int) -> float:
    t, w = gl01(20)
    return float(2 * np.pi * np.sum(w * legendre.legval(t, np.eye(l + 1)[l]) * t))


def sh_irradiance(n: np.ndarray, order: int) -> np.ndarray:
    """E_N at unit normals n (V, 3), the module docstring's Funk-Hecke sum."""
    c = n @ MU
    return sum(a_l(l) * lambda_l(l) * (2 * l + 1) / (4 * np.pi) * legendre.legval(c, np.eye(l + 1)[l])
               for l in range(order + 1))


def exact_irradiance(n: np.ndarray) -> np.ndarray:
    """int over the hemisphere about n of L(w) (n.w) dw: Gauss-Legendre in cos x uniform phi, per normal."""
    t, wt = gl01(64)
    phi = (np.arange(128) + 0.5) * 2 * np.pi / 128
    tt, pp = np.repeat(t, 128), np.tile(phi, 64)
    weights = np.repeat(wt, 128) * tt * (2 * np.pi / 128)
    r = np.sqrt(1 - tt * tt)
    out = np.empty(len(n))
    for i, nz in enumerate(n):
        a = np.array([1.0, 0.0, 0.0]) if abs(nz[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
        tx = np.cross(nz, a)
        tx /= np.linalg.norm(tx)
        ty = np.cross(nz, tx)
        d = (r * np.cos(pp))[:, None] * tx + (r * np.sin(pp))[:, None] * ty + tt[:, None] * nz
        out[i] = np.sum(weights * lobe(d))
    return out


def lobe_coefficients(order: int) -> np.ndarray:
    """L's SH coefficients (K,) by Gauss-Legendre x phi (40 x 80: L is a degree-~50 polynomial to 1e-12)."""
    z, wz = legendre.leggauss(40)
    phi = (np.arange(80) + 0.5) * 2 * np.pi / 80
    zz, pp = np.repeat(z, 80), np.tile(phi, 40)
    r = np.sqrt(1 - zz * zz)
    d = np.stack([r * np.cos(pp), r * np.sin(pp), zz], axis=-1)
    w = np.repeat(wz, 80) * (2 * np.pi / 80)
    return (sh_basis(d, order) * (w * lobe(d))[:, None]).sum(axis=0)


@pytest.fixture(scope="module")
def sphere():
    scene = scenes.load("builtin:sphere-diffuse")
    objs = transfer_objects(scene)
    return objs, objs[0].normals / np.linalg.norm(objs[0].normals, axis=1, keepdims=True)


def prt_irradiance(t: np.ndarray, order: int) -> np.ndarray:
    return np.einsum("k,vk->v", lobe_coefficients(order), t[:, :, 0].astype(np.float64))


@pytest.mark.parametrize("shadowed", [False, True])
def test_order_8_prt_of_a_convex_sphere_is_order_8_sh_irradiance(sphere, shadowed):
    objs, n = sphere
    (t,) = transfer(objs, 8, 16, 0, shadowed=shadowed)
    assert t.shape == (len(n), 81, 3)
    e = prt_irradiance(t, 8)
    want = sh_irradiance(n, 8)
    scale = np.abs(want).max()
    np.testing.assert_allclose(e, want, atol=1e-5 * scale)  # float32 transfer: ~1e-7
    # negative control: the same transfer read as order 7 (its first 64 coefficients) misses band 8 (A_8 != 0)
    e7 = np.einsum("k,vk->v", lobe_coefficients(7), t[:, :64, 0].astype(np.float64))
    assert np.abs(e7 - want).max() > 1e-4 * scale
    np.testing.assert_allclose(e7, sh_irradiance(n, 7), atol=1e-5 * scale)


def test_a_convex_sphere_is_unshadowed_bit_for_bit_at_order_8(sphere):
    objs, _ = sphere
    (shadowed,) = transfer(objs, 8, 16, 0, shadowed=True)
    (unshadowed,) = transfer(objs, 8, 16, 0, shadowed=False)
    np.testing.assert_array_equal(shadowed, unshadowed)


def test_prt_converges_to_the_exact_irradiance_as_the_order_grows(sphere):
    objs, n = sphere
    exact = exact_irradiance(n)
    errors = []
    for order in (2, 4, 6, 8):
        (t,) = transfer(objs, order, 1, 0, shadowed=False)
        errors.append(np.abs(prt_irradiance(t, order) - exact).max() / exact.max())
    # the truncation error is the tail sum_{l > N} A_l lambda_l P_l: it shrinks with every even band
    assert all(b < a for a, b in zip(errors, errors[1:], strict=False)), errors
    # and it is the tail: the order-8 error is the Funk-Hecke remainder of bands 9..40
    tail = np.abs(sh_irradiance(n, 40) - sh_irradiance(n, 8)).max() / exact.max()
    assert errors[-1] == pytest.approx(tail, rel=1e-3)
    np.testing.assert_allclose(sh_irradiance(n, 40), exact, atol=1e-7 * exact.max())


def test_the_cache_key_and_memory_estimate_include_the_order(sphere, monkeypatch):
    objs, n = sphere
    assert transfer_key(objs, 8, 16, 0, True) != transfer_key(objs, 7, 16, 0, True)
    v = len(n)
    # the transfer arrays are V x (order + 1)^2 x ...: order 8 needs 81 / 25 of order 4's (unshadowed)
    assert transfer_bytes(v, 8, 1, 0, False) / transfer_bytes(v, 4, 1, 0, False) == pytest.approx(81 / 25)
    need = transfer_bytes(v, 8, 16, 2, True)
    monkeypatch.setattr("realtime.techniques.prt.prt_transfer.memory_limit", lambda: need - 1)
    with pytest.raises(MemoryError, match="order 8 \\(81 coefficients\\).*GiB"):
        transfer(objs, 8, 16, 2, shadowed=True)
    check_memory(v, 7, 16, 2, True)  # order 7 fits under the same limit
    assert memory_limit() > 0


@pytest.mark.slow
@pytest.mark.parametrize("order", [2, 4, 6, 8])
def test_precompute_timing(order, record_property):
    # a figure, not a bound: sphere-on-plane, shadowed, 256 rays, 1 bounce
    objs = transfer_objects(scenes.load("builtin:sphere-on-plane"))
    t0 = time.perf_counter()
    transfer(objs, order, 256, 1, shadowed=True)
    seconds = time.perf_counter() - t0
    record_property("precompute_s", seconds)
    print(f"order {order}: {sum(len(o.positions) for o in objs)} vertices, {seconds:.2f} s")
