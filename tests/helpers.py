"""Small helpers shared by tests (import as `from tests.helpers import ...`)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from groundtruth.exact import raycast
from realtime.engine.environment_maps import filled_store
from realtime.techniques.vct import vct_math
from realtime.techniques.vct.vct import VoxelScene
from scenes.environment.directions import equirect_directions
from scenes.model.scene import Scene

#: overrides for a real-time render whose image alone a test reads: one frame and no warm-up, where a scene's
#: defaults time 30 frames after 5 (each re-voxelising, re-injecting and re-filtering: 36 times the work).
#: Frame times are measured by the benchmarks and experiments, never by tests.
IMAGE_ONLY = {"realtime.timing_frames": 1, "realtime.warmup_frames": 0}


def write_scene(tmp_path: Path, text: str, name: str = "scene.toml") -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


def sphere_scene_text(name: str, environment: str, material: str, size: int, shape: str = "sphere",
                      object_lines: str = "", tables: str = "") -> str:
    """TOML of one object seen from z = 4 with a 32-degree fov; `environment` holds the body of the
    [environment] table, `object_lines` extra keys of the object, `tables` whole extra tables."""
    obj = f'shape = "{shape}"\n' + (object_lines + "\n" if object_lines else "") + f"material = {material}"
    return (f'\nname = "{name}"\n[environment]\n{environment}\n[camera]\norigin = [0.0, 0.0, 4.0]\n'
            f"fov_deg = 32.0\nwidth = {size}\nheight = {size}\n[[objects]]\n{obj}\n{tables}\n")


def unit_sphere_hits(camera, margin_px: float = 2.5):
    """(normals (H, W, 3), views towards the camera, interior mask) where each pixel-centre ray meets the
    unit sphere at the origin, computed analytically (independent of the mesh and the renderers).
    `interior`: the ray passes at least `margin_px` pixels inside the silhouette."""
    import numpy as np

    o = np.asarray(camera.origin, dtype=np.float64)
    d = camera.pixel_rays()
    b = d @ o
    n = o + (-b - np.sqrt(np.maximum(b * b - (o @ o - 1.0), 0.0)))[..., None] * d
    closest = np.sqrt(np.maximum(o @ o - b * b, 0.0))
    interior = closest < 1.0 - margin_px * np.radians(camera.fov_deg) / camera.height * np.linalg.norm(o)
    return n, -d, interior


def box_chain(env, base: int) -> list:
    """The paper's mip chain built here in numpy: level 0 the Mitsuba-convention lookup of every texel
    direction of a base x base cube (docs/contract.md section 2), then 2 x 2 box means down to 1 x 1; float64."""
    from scenes.environment import cubemap, envmap

    levels = [envmap.lookup(env, cubemap.texel_directions(base)).astype(np.float64)]
    while levels[-1].shape[1] > 1:
        f = levels[-1]
        s = f.shape[1] // 2
        levels.append(f.reshape(6, s, 2, s, 2, 3).mean(axis=(2, 4)))
    return levels


def bilinear(level: np.ndarray, face: np.ndarray, s: np.ndarray, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Bilinear lookup inside one face; `inside`: the 2 x 2 footprint lies on the face."""
    size = level.shape[1]
    x, y = s * size - 0.5, t * size - 0.5
    i0, j0 = np.floor(x).astype(np.int64), np.floor(y).astype(np.int64)
    fx, fy = (x - i0)[:, None], (y - j0)[:, None]
    inside = (i0 >= 0) & (j0 >= 0) & (i0 + 1 < size) & (j0 + 1 < size)
    i, j = np.clip(i0, 0, max(size - 2, 0)), np.clip(j0, 0, max(size - 2, 0))
    value = (level[face, j, i] * (1 - fx) * (1 - fy) + level[face, j, i + 1] * fx * (1 - fy)
             + level[face, j + 1, i] * (1 - fx) * fy + level[face, j + 1, i + 1] * fx * fy)
    return value, inside


def trilinear(chain: list[np.ndarray], d: np.ndarray, lod: float) -> tuple[np.ndarray, np.ndarray]:
    """The chain read at `lod` along directions d (N, 3): bilinear in levels floor(lod) and floor(lod) + 1,
    linear between them; `inside`: both footprints lie on one face (no seamless blending across edges)."""
    from scenes.environment import cubemap

    face, s, t = cubemap.direction_to_face(d)
    lo = int(np.floor(lod))
    hi = min(lo + 1, len(chain) - 1)
    w = lod - lo
    a, inside_a = bilinear(chain[lo], face, s, t)
    b, inside_b = bilinear(chain[hi], face, s, t)
    return (1 - w) * a + w * b, inside_a & inside_b


def scene_voxels(ctx, scene: Scene, resolution: int, objects: list | None = None,
                 grid: vct_math.Cascades | None = None) -> VoxelScene:
    """The scene's objects (or `objects`) voxelised and injected at `resolution`^3, one cascade (or `grid`), six
    cones, step 0.5, under the scene's environment (its SH9 from a 64^2 filter); the caller releases the voxels."""
    env = filled_store(ctx, scene)
    vs = VoxelScene(ctx, scene.objects if objects is None else objects, resolution, 1, 6, 0.5, grid=grid)
    vs.update(None, env.sh_buffer)
    env.release()
    return vs


#: the cap maps' half-angle: inside the cube face about the cap's axis (whose edges are 45 degrees from its centre)
CAP_HALF_ANGLE = np.radians(20.0)


def cap_map(axis=(0.0, 1.0, 0.0), height: int = 512) -> np.ndarray:
    """An equirect map (H, 2H, 3) of radiance 1 with a cap of CAP_HALF_ANGLE about `axis` at 11, whose lobe
    integrals and face means have closed forms."""
    inside = equirect_directions(height, 2 * height) @ np.asarray(axis, dtype=np.float64) > np.cos(CAP_HALF_ANGLE)
    return np.repeat(np.where(inside, 11.0, 1.0)[..., None], 3, axis=-1).astype(np.float32)


def predicted_back(s: Scene) -> tuple[np.ndarray, np.ndarray]:
    """(hit, n.v <= 0) at every pixel centre, from the numpy ray cast (same mesh, same vertex normals)."""
    hits = raycast.cast(s, subpixels=1)
    n_dot_v = np.sum(hits.normal[..., 0, :] * -hits.direction[..., 0, :], axis=-1)
    return hits.hit[..., 0], hits.hit[..., 0] & (n_dot_v <= 0)
