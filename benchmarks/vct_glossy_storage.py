"""How much of torus-phong's one-bounce excess under voxel cone tracing its six-face storage of glossy exitance
explains, with everything else exact (docs/voxel-cone-tracing-measurements.md, "The six-face storage alone").

    .venv/bin/python benchmarks/vct_glossy_storage.py [--pixels 64] [--subpixels 4] [--lobe 32] [--sender 64]
                                                      [--path-tracer-spp 1024]

The scene's camera sees the analytic torus (ring 0.7, tube 0.3, Phong ks 0.9, N 50, under its probe) through
`--subpixels`^2 rays a pixel, averaged as the path tracer's box filter averages them; a pixel counts where at
least half its rays meet the torus, as the path tracer's mask counts it. At each ray's hit the receiver's Phong
lobe about the view's mirror is sampled (`--lobe` directions, none below the horizon), each direction
ray-marched against the torus's distance function. Where it meets the torus at y, what
y sends back toward the receiver, along -w, is taken three ways:

- exact: ks times the mean, over `--sender` directions of y's own lobe about the mirror of w, of the
  environment it sees unoccluded above y (the paper's reflectance, one bounce);
- six faces: as the voxels store it and a cone reads it (vct_inject.comp, vct_trace.glsl's vct_read): face f
  holds the exact exitance toward e_f where y's surface faces e_f, premultiplied by the axis's coverage
  |n_a| / |n|_inf; a cone along w reads, per axis, the face pointing against w, weighted w_a^2, normalised by
  the weights of the faces that carry light;
- deferred: the exact unoccluded exitance toward -w (what a read that evaluates the stored normal and lobe
  against the environment would give) times the visibility blended over the faces as the six-face read blends
  it;
- deferred, visibility at the mirror: the same unoccluded exitance times the lobe's visibility about y's own
  mirror of w (what a per-direction visibility would give): what is left is the read's factorisation, the
  environment's lobe mean times the lobe's unblocked share, where the truth is the lobe's mean of the two's
  product;
- deferred, nearest diffuse cone: the visibility that of the one of y's six diffuse cones (vct_math.cone_set,
  in vct_math.tangent_frame) whose axis is nearest y's mirror of w, each cone's the unblocked share of
  `--sender` directions uniform over its cap and above y (what storing the injection's six cone visibilities
  a voxel would give).

Prints the one-bounce means over the torus's pixels and their ratios to the exact one. No voxels, no cone
footprint: the ratios isolate the directional storage. With `--path-tracer-spp` it also renders the path
tracer's max_depth 2 and 3 at the same pixels (Mitsuba) and compares the direct light and the exact bounce,
the model's check against the reference.
"""

from __future__ import annotations

import argparse
import math

import numpy as np

import scenes
from groundtruth.pathtracer import reference
from realtime.techniques.vct import vct_math
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


def march(origins: np.ndarray, dirs: np.ndarray, t_max: float = 6.0,
          max_steps: int = 5000) -> tuple[np.ndarray, np.ndarray]:
    """Sphere tracing against the torus: (hit, point) per ray. Steps of 0.9 d until d < 1e-5 or t > t_max.

    A ray grazing the tube creeps along it in many short steps; a fixed small step count leaves such rays
    unresolved, and counting them as misses lets senders see sky they do not see (with 200 steps, 0.2-0.4 %
    of the lobes' rays, which raised the exact bounce by 5 %). Only the live rays are stepped, until none is
    left; a ray still live after `max_steps` is an error."""
    shape = origins.shape[:-1]
    o, d = origins.reshape(-1, 3), dirs.reshape(-1, 3)
    t = np.zeros(len(o))
    hit = np.zeros(len(o), bool)
    live = np.arange(len(o))
    for _ in range(max_steps):
        dist = torus_distance(o[live] + t[live, None] * d[live])
        done = dist < 1e-5
        hit[live[done]] = True
        t[live] += np.where(done, 0.0, 0.9 * dist)
        live = live[~done & (t[live] < t_max)]
        if live.size == 0:
            break
    else:
        raise RuntimeError(f"{live.size} rays unresolved after {max_steps} sphere-tracing steps")
    return hit.reshape(shape), (o + t[:, None] * d).reshape(*shape, 3)


def tangents(axis: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two unit vectors across each row of `axis` (M, 3), by vct_math.tangent_frame's helper-axis rule."""
    helper = np.where(np.abs(axis[:, 1:2]) < 0.9, [[0.0, 1.0, 0.0]], [[1.0, 0.0, 0.0]])
    t1 = np.cross(helper, axis)
    t1 /= np.linalg.norm(t1, axis=-1, keepdims=True)
    return t1, np.cross(axis, t1)


def directions_about(axis: np.ndarray, cos_a: np.ndarray, phi: np.ndarray) -> np.ndarray:
    """(M, K, 3): the directions at polar cos_a and azimuth phi (M, K) about each row of `axis` (M, 3)."""
    t1, t2 = tangents(axis)
    sin_a = np.sqrt(np.maximum(0.0, 1.0 - cos_a ** 2))
    return ((sin_a * np.cos(phi))[..., None] * t1[:, None] + (sin_a * np.sin(phi))[..., None] * t2[:, None]
            + cos_a[..., None] * axis[:, None])


def lobe_directions(axis: np.ndarray, count: int, rng: np.random.Generator) -> np.ndarray:
    """`count` directions per row of `axis` (M, 3) from the normalised Phong lobe: cos a = xi^(1 / (N + 1))."""
    xi1, xi2 = rng.random((len(axis), count)), rng.random((len(axis), count))
    return directions_about(axis, xi1 ** (1.0 / (EXPONENT + 1.0)), 2.0 * math.pi * xi2)


def cap_directions(axis: np.ndarray, half_angle: float, count: int, rng: np.random.Generator) -> np.ndarray:
    """`count` directions per row of `axis` (M, 3) uniform over the cap of `half_angle` (radians) about it."""
    xi1, xi2 = rng.random((len(axis), count)), rng.random((len(axis), count))
    return directions_about(axis, 1.0 - xi1 * (1.0 - math.cos(half_angle)), 2.0 * math.pi * xi2)


def nearest_diffuse_cone_visibility(p: np.ndarray, n: np.ndarray, towards: np.ndarray, samples: int) -> np.ndarray:
    """(M,): the unblocked share, above p, of `samples` directions uniform over the one of p's six diffuse cones
    (vct_math.cone_set in vct_math.tangent_frame's frame of n, the shading's cones) whose axis is nearest
    `towards`."""
    cones = vct_math.cone_set(6)
    frame = np.stack([*tangents(n), n], 1)  # rows t, b, n per point
    axes = cones.directions @ frame  # (M, 6, 3)
    nearest = axes[np.arange(len(p)), np.argmax((axes * towards[:, None]).sum(-1), 1)]
    w = cap_directions(nearest, cones.half_angle, samples, np.random.default_rng(5))
    above = (w * n[:, None]).sum(-1) > 0.0
    # a grazing ray can creep along the tube for thousands of steps
    blocked, _ = march(np.broadcast_to(p[:, None] + EPSILON * n[:, None], w.shape).copy(), w, max_steps=20000)
    return np.where(above.any(1), (above & ~blocked).sum(1) / np.maximum(above.sum(1), 1), 1.0)


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


def one_bounce_images(scene, pixels: int, subpixels: int, lobe: int, sender_samples: int) -> dict[str, np.ndarray]:
    """Per-pixel means over each pixel's subpixel rays (the scene camera's `subpixel_rays`, averaged as the path
    tracer's box filter averages them): what the camera sees with direct light only ("direct": the torus's
    reflection of the environment, the environment itself where a ray misses), the one bounce with the
    sender's exitance taken exactly, from six faces, and deferred (above; a ray that misses adds no bounce),
    rgb (pixels, pixels, 3) each; and "covered", the pixels at least half of whose rays meet the torus (the
    path tracer's mask)."""
    env = np.asarray(scene.environment.radiance(), np.float64)
    sender = Sender(env, scene.environment.rotation_deg, sender_samples)
    camera = scene.with_overrides({"camera.width": pixels, "camera.height": pixels}).camera
    rays = camera.subpixel_rays(subpixels).reshape(-1, 3)
    hit, x = march(np.broadcast_to(np.asarray(camera.origin, float), rays.shape).copy(), rays)
    x, view = x[hit], -rays[hit]
    n = torus_normal(x)
    r = mirror(-view, n)

    w = lobe_directions(r, lobe, np.random.default_rng(1))
    above = (w * n[:, None]).sum(-1) > 0.0
    met, y = march(np.broadcast_to(x[:, None] + EPSILON * n[:, None], w.shape).copy(), w)
    ok = met & above
    y, wy = y[ok], w[ok]
    ny = torus_normal(y)
    at_mirror = sender.lobe(y, ny, mirror(wy, ny))
    blend, carried = face_blend(wy, ny, lambda m: sender.lobe(y, ny, m))
    per_ray = {"exact": at_mirror[:, :3],
               "six faces": np.where(carried[:, None], blend[:, :3], 0.0),
               "deferred": np.where(carried[:, None], at_mirror[:, 3:6] * blend[:, 6:7], 0.0),
               "deferred, visibility at the mirror": at_mirror[:, 3:6] * at_mirror[:, 6:7],
               "deferred, nearest diffuse cone": at_mirror[:, 3:6] * nearest_diffuse_cone_visibility(
                   y, ny, mirror(wy, ny), sender_samples)[:, None]}

    def image(values_at_hits: np.ndarray, background: np.ndarray | None = None) -> np.ndarray:
        full = np.zeros((len(rays), 3)) if background is None else background.copy()
        full[hit] = values_at_hits
        return full.reshape(pixels, pixels, subpixels ** 2, 3).mean(2)

    sky = envmap.lookup(env, rays, scene.environment.rotation_deg).astype(np.float64)
    images = {"direct": image(sender.lobe(x, n, r)[:, :3], sky)}
    for name, values in per_ray.items():
        full = np.zeros((*w.shape[:2], 3))
        full[ok] = values
        images[name] = image(KS * full.mean(1))
    images["covered"] = hit.reshape(pixels, pixels, subpixels ** 2).mean(2) >= 0.5
    return images


def path_traced_one_bounce(scene, pixels: int, spp: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The path tracer's direct light (max_depth 2), one bounce (max_depth 3 minus 2) and mask, at the same
    pixels (needs Mitsuba)."""
    renders = [reference.render(scene.with_overrides({"camera.width": pixels, "camera.height": pixels,
                                                      "reference.spp": spp, "reference.integrator": "path",
                                                      "reference.max_depth": depth})) for depth in (2, 3)]
    return renders[0].rgb, renders[1].rgb - renders[0].rgb, renders[0].mask & renders[1].mask


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--pixels", type=int, default=64)
    parser.add_argument("--subpixels", type=int, default=4, help="a pixel is integrated over N x N rays")
    parser.add_argument("--lobe", type=int, default=32)
    parser.add_argument("--sender", type=int, default=64)
    parser.add_argument("--path-tracer-spp", type=int, default=0,
                        help="also render the path tracer's one bounce at this many samples a pixel and compare")
    args = parser.parse_args()
    scene = scenes.load("builtin:torus-phong")
    images = one_bounce_images(scene, args.pixels, args.subpixels, args.lobe, args.sender)
    mask = images["covered"]
    if args.path_tracer_spp:
        pt_direct, pt_bounce, pt_mask = path_traced_one_bounce(scene, args.pixels, args.path_tracer_spp)
        mask = mask & pt_mask
    exact = float(images["exact"][mask].mean())
    print(f"{int(mask.sum())} torus pixels of {args.pixels ** 2}, {args.subpixels ** 2} rays each")
    for name in ("exact", "six faces", "deferred", "deferred, visibility at the mirror",
                 "deferred, nearest diffuse cone"):
        value = float(images[name][mask].mean())
        print(f"one bounce, {name:34s}: {value:.5f}  ({value / exact:.3f} of exact)")
    if args.path_tracer_spp:
        direct = float(images["direct"][mask].mean())
        print(f"direct light: model {direct:.4f}, path tracer {float(pt_direct[mask].mean()):.4f}")
        print(f"one bounce: model exact {exact:.5f}, path tracer {float(pt_bounce[mask].mean()):.5f} "
              f"({exact / float(pt_bounce[mask].mean()):.3f} of it)")


if __name__ == "__main__":
    main()
