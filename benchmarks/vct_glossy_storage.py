"""How much of torus-phong's one-bounce excess under voxel cone tracing its six-face storage of glossy exitance
explains, with everything else exact (docs/voxel-cone-tracing-measurements.md, "The torus's glossy storage").

    .venv/bin/python benchmarks/vct_glossy_storage.py [--pixels 64] [--lobe 64] [--sender 128]

The scene's camera sees the analytic torus (ring 0.7, tube 0.3, Phong ks 0.9, N 50, under its probe); at each
pixel the receiver's Phong lobe about the view's mirror is sampled (`--lobe` directions, none below the
horizon), each direction ray-marched against the torus's distance function. Where it meets the torus at y, what
y sends back toward the receiver, along -w, is taken three ways:

- exact: ks times the mean, over `--sender` directions of y's own lobe about the mirror of w, of the
  environment it sees unoccluded above y (the paper's reflectance, one bounce);
- six faces: as the voxels store it and a cone reads it (vct_inject.comp, vct_trace.glsl's vct_read): face f
  holds the exact exitance toward e_f where y's surface faces e_f, premultiplied by the axis's coverage
  |n_a| / |n|_inf; a cone along w reads, per axis, the face pointing against w, weighted w_a^2, normalised by
  the weights of the faces that carry light;
- deferred: the exact unoccluded exitance toward -w (what a read that evaluates the stored normal and lobe
  against the environment would give) times the visibility blended over the faces as the six-face read blends
  it.

Prints the one-bounce means over the torus's pixels and their ratios to the exact one. No voxels, no cone
footprint: the ratios isolate the directional storage.
"""

from __future__ import annotations

import argparse
import math

import numpy as np

import scenes
from scenes.environment import envmap

RING, TUBE, KS, EXPONENT = 0.7, 0.3, 0.9, 50.0
#: rays leave a surface this far along its normal
EPSILON = 1e-3


def torus_distance(p: np.ndarray) -> np.ndarray:
    q = np.sqrt(p[..., 0] ** 2 + p[..., 2] ** 2) - RING
    return np.sqrt(q ** 2 + p[..., 1] ** 2) - TUBE


def torus_normal(p: np.ndarray) -> np.ndarray:
    ring = p.copy()
    ring[..., 1] = 0.0
    ring *= RING / np.linalg.norm(ring, axis=-1, keepdims=True)
    n = p - ring
    return n / np.linalg.norm(n, axis=-1, keepdims=True)


def march(origins: np.ndarray, dirs: np.ndarray, t_max: float = 6.0) -> tuple[np.ndarray, np.ndarray]:
    """Sphere tracing against the torus: (hit, point) per ray."""
    t = np.zeros(origins.shape[:-1])
    hit = np.zeros(t.shape, bool)
    alive = np.ones(t.shape, bool)
    for _ in range(200):
        d = torus_distance(origins + t[..., None] * dirs)
        now = alive & (d < 1e-5)
        hit |= now
        alive &= ~now
        t = np.where(alive, t + 0.9 * d, t)
        alive &= t < t_max
    return hit, origins + t[..., None] * dirs


def lobe_directions(axis: np.ndarray, count: int, rng: np.random.Generator) -> np.ndarray:
    """`count` directions per row of `axis` (M, 3) from the normalised Phong lobe: cos a = xi^(1 / (N + 1))."""
    xi1, xi2 = rng.random((len(axis), count)), rng.random((len(axis), count))
    cos_a = xi1 ** (1.0 / (EXPONENT + 1.0))
    sin_a = np.sqrt(1.0 - cos_a ** 2)
    phi = 2.0 * math.pi * xi2
    helper = np.where(np.abs(axis[:, 1:2]) < 0.9, [[0.0, 1.0, 0.0]], [[1.0, 0.0, 0.0]])
    t1 = np.cross(helper, axis)
    t1 /= np.linalg.norm(t1, axis=-1, keepdims=True)
    t2 = np.cross(axis, t1)
    return ((sin_a * np.cos(phi))[..., None] * t1[:, None] + (sin_a * np.sin(phi))[..., None] * t2[:, None]
            + cos_a[..., None] * axis[:, None])


def mirror(incident: np.ndarray, n: np.ndarray) -> np.ndarray:
    return incident - 2.0 * (incident * n).sum(-1, keepdims=True) * n


class Sender:
    """What torus points send: per point, from one set of directions of its lobe about a mirror direction."""

    def __init__(self, env: np.ndarray, rotation_deg: float, samples: int) -> None:
        self.env, self.rotation_deg, self.samples = env, rotation_deg, samples

    def lobe(self, p: np.ndarray, n: np.ndarray, r: np.ndarray) -> np.ndarray:
        """(M, 7): ks times the lobe's mean of the environment seen unoccluded above p (rgb), the same ignoring
        occlusion (rgb), and the share of the lobe's directions above p that are unoccluded."""
        w = lobe_directions(r, self.samples, np.random.default_rng(3))
        above = (w * n[:, None]).sum(-1) > 0.0
        blocked, _ = march(np.broadcast_to(p[:, None] + EPSILON * n[:, None], w.shape).copy(), w)
        seen = above & ~blocked
        radiance = envmap.lookup(self.env, w, self.rotation_deg).astype(np.float64)
        visibility = np.where(above.any(1), seen.sum(1) / np.maximum(above.sum(1), 1), 1.0)
        return np.concatenate([KS * (radiance * seen[..., None]).mean(1), KS * (radiance * above[..., None]).mean(1),
                               visibility[:, None]], 1)


def face_blend(w: np.ndarray, n: np.ndarray, per_face) -> tuple[np.ndarray, np.ndarray]:
    """The six-face read along w of a surface of normal n: per axis the face pointing against w, weighted
    w_a^2 times the axis's coverage, where the surface faces it; per_face(mirror direction) gives the face's
    values (M, K). Returns the blend (M, K) and where any face carries light (M,)."""
    cover = np.abs(n) / np.abs(n).max(-1, keepdims=True)
    num, den = 0.0, np.zeros(len(w))
    for a in range(3):
        f = np.zeros_like(w)
        f[:, a] = -np.sign(w[:, a])
        weight = w[:, a] ** 2 * cover[:, a] * ((n * f).sum(-1) > 0.0)
        num = num + weight[:, None] * per_face(mirror(-f, n))
        den += weight
    return num / np.maximum(den, 1e-12)[:, None], den > 0.0


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--pixels", type=int, default=64)
    parser.add_argument("--lobe", type=int, default=64)
    parser.add_argument("--sender", type=int, default=128)
    args = parser.parse_args()
    scene = scenes.load("builtin:torus-phong")
    env = np.asarray(scene.environment.radiance(), np.float64)
    sender = Sender(env, scene.environment.rotation_deg, args.sender)

    cam = np.asarray(scene.camera.origin, float)
    forward = np.asarray(scene.camera.target, float) - cam
    forward /= np.linalg.norm(forward)
    right = np.cross(forward, [0.0, 1.0, 0.0])
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    px, tan_half = args.pixels, math.tan(math.radians(scene.camera.fov_deg) / 2.0)
    s = (np.arange(px) + 0.5) / px * 2.0 - 1.0
    ys, xs = np.meshgrid(s, s, indexing="ij")
    rays = forward + tan_half * (xs[..., None] * right - ys[..., None] * up)
    rays = (rays / np.linalg.norm(rays, axis=-1, keepdims=True)).reshape(-1, 3)
    hit, x = march(np.broadcast_to(cam, rays.shape).copy(), rays)
    x, view = x[hit], -rays[hit]
    n = torus_normal(x)

    w = lobe_directions(mirror(-view, n), args.lobe, np.random.default_rng(1))
    above = (w * n[:, None]).sum(-1) > 0.0
    met, y = march(np.broadcast_to(x[:, None] + EPSILON * n[:, None], w.shape).copy(), w)
    ok = met & above
    y, wy = y[ok], w[ok]
    ny = torus_normal(y)
    at_mirror = sender.lobe(y, ny, mirror(wy, ny))
    blend, carried = face_blend(wy, ny, lambda r: sender.lobe(y, ny, r))
    exact = at_mirror[:, :3]
    faces = np.where(carried[:, None], blend[:, :3], 0.0)
    deferred = np.where(carried[:, None], at_mirror[:, 3:6] * blend[:, 6:7], 0.0)

    def bounce(values: np.ndarray) -> float:
        full = np.zeros(w.shape)
        full[ok] = values
        return float((KS * full.mean(1)).mean())

    one = {"exact": bounce(exact), "six faces": bounce(faces), "deferred": bounce(deferred)}
    print(f"{len(x)} torus pixels of {px * px}, {ok.mean():.3f} of the lobes' rays meet the torus")
    for name, value in one.items():
        print(f"one bounce, {name:9s}: {value:.5f}  ({value / one['exact']:.3f} of exact)")


if __name__ == "__main__":
    main()
