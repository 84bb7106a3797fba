"""E10 of the paper suite: what interreflection costs in real time, by cascaded voxel cone tracing.

On cornell-open, bowl-diffuse and torus-phong, against the same path-traced references, `psnr_unbiased`
against the frame's milliseconds for
(a) direct only (the paper), (b) + VCT occlusion, (c) + VCT occlusion + interreflection,
over `[realtime.vct]` resolution x cascades x diffuse cones (QUICK: a subset that fits the time limit);
beside them on the same accuracy-time axes, the other ways to shadows and bounces (E8's override helpers):
PRT of order 4 with one bounce (diffuse scenes) and a geodesic light array with shadow maps.
Per configuration: the voxel memory (six RGBA16F faces with their mips, every cascade) against a single
3D texture with the same finest voxel over the same extent; `trace` = the shading pass's ms minus the
direct-only pass's (the cones run inside `draw`).

Energy, in linear radiance over the covered pixels against the path tracer at max_depth 2 (direct light with
occlusion), 3, 4, 5 (one, two, three bounces), the real-time images rendered `Settings.energy_subpixels` times
larger and box-reduced (scenes.model.render.pixel_area_means) so that their pixels are area integrals as the path
tracer's are: at each resolution (the best setting's cascades and cones) the
indirect energy ratio (VCT (c) - (b)) / (path depth 3 - depth 2), and at the best setting the same for
`[realtime.vct] bounces` 1, 2, 3 against depth 2 + bounces.
The thin-wall hard case (thin-wall scene, realtime.vct.VoxelScene.probe): the irradiance the cones find
just inside a one-voxel wall of a closed box over the irradiance just outside it (the leak), at every
resolution, at the grid's own placement and over placements shifted by fractions of a voxel (the leak
depends on where the walls fall in the coarse texels), with the box as modelled (walls along the grid's axes)
and turned obliquely to them (`Settings.leak_rotations`).
The seed's storage comparison (e10_voxel_storage.py): the cascaded texture against a dense 3D texture, a sparse
voxel octree, a Morton-ordered octree and a sparse voxel DAG of the same voxels, on procedural atriums of growing
size (up to 2e6 triangles) at 32^3 ... 512^3: voxel count, build time and memory, and whether the seed's claim
(the cascades' advantage grows with resolution and scene size) holds, computed from the ratios.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

import realtime
import scenes
from experiments.measure import convergence, metrics
from experiments.measure.results import ResultRow
from experiments.paper import e10_voxel_storage
from experiments.paper.context import Context
from experiments.paper.e08_occlusion import lights_ov, prt_ov
from experiments.publish import plots, report
from experiments.publish.plots import frame_ms
from experiments.publish.report import Section, f2, f3, f4, unbiased_cell
from groundtruth.pathtracer import reference
from realtime.engine.context import get_context
from realtime.engine.environment_maps import filled_store
from realtime.techniques.vct import vct, vct_math
from realtime.techniques.vct.vct import VoxelScene
from scenes.environment.directions import rotation_xyz
from scenes.geometry import meshes
from scenes.model.render import Render, pixel_area_means
from scenes.model.scene import Material

NUMBER = 10
TITLE = "E10 what interreflection costs (voxel cone tracing)"

SCENES = (("cornell-open", "builtin:cornell-open"), ("bowl-diffuse", "builtin:bowl-diffuse"),
          ("torus-phong", "builtin:torus-phong"))


@dataclass(frozen=True)
class Settings:
    grid: tuple[tuple[int, int, int], ...]  # (resolution, cascades, diffuse cones)
    frames: int
    bounces: tuple[int, ...]  # [realtime.vct] bounces of the energy table, against path depth 2 + bounces
    energy_resolutions: tuple[int, ...]  # the energy table's resolutions (the best setting's cascades, cones)
    leak_resolutions: tuple[int, ...]
    leak_offsets: int  # grid placements of the thin-wall leak (the first is the grid's own)
    leak_rotations: tuple[tuple[float, float, float], ...]  # the thin-wall scene turned (rotation_xyz, degrees)
    ladder: bool  # PRT and light-array rows beside VCT's
    # the energy table's real-time images are rendered this many times larger per axis and box-reduced: a
    # point sample at a silhouette pixel's centre stands for the whole pixel, where the path tracer integrates
    # the part the object covers (torus-phong's glossy bounce sits in such pixels: at 64^3 and 192^2 px its
    # ratio reads 1.64 point-sampled, 1.40 integrated over 4 x 4 rays a pixel); not 2: with
    # 2 x 2 samples a silhouette pixel is often exactly half covered, a tie the half-coverage mask counts as
    # covered (torus-phong at 48^2 px: 18 pixels off the path tracer's mask, 6 with 1 or 4)
    energy_subpixels: int
    storage: e10_voxel_storage.Settings  # the seed's storage comparison on the procedural atrium

    def __post_init__(self) -> None:
        # the energy table's one-bounce columns (by resolution, the brightest pixels) compare with path depth 3
        if 1 not in self.bounces:
            raise ValueError(f"E10 settings: bounces must include 1 (the one-bounce energy), got {self.bounces}")


QUICK = Settings(grid=((32, 1, 6), (64, 2, 6)), frames=1, bounces=(1, 2), energy_resolutions=(32, 64),
                 leak_resolutions=(32, 64), leak_offsets=2, leak_rotations=((0.0, 0.0, 0.0), (20.0, 25.0, 0.0)),
                 ladder=True, energy_subpixels=3, storage=e10_voxel_storage.QUICK)
# a subset of 32/64/128 x 1/2/3 cascades x 4/6/9 cones that fits the suite's time here (128^3 takes about 15 s a
# frame on llvmpipe, its injection most of it): every resolution at one cascade, 2 and 3 cascades at 64^3, and 4
# and 9 cones at 64^3 x 2; one timed frame after one warm-up frame
FULL = Settings(grid=((32, 1, 6), (64, 1, 6), (128, 1, 6), (64, 2, 6), (64, 3, 6), (64, 2, 4), (64, 2, 9)),
                frames=1, bounces=(1, 2, 3), energy_resolutions=(32, 64, 128), leak_resolutions=(32, 64, 128),
                leak_offsets=5, leak_rotations=((0.0, 0.0, 0.0), (20.0, 25.0, 0.0)), ladder=True,
                energy_subpixels=4, storage=e10_voxel_storage.FULL)
#: the energy table also gives the share of each one-bounce image's light held by its brightest 2 % of pixels:
#: a mean ratio near or far from 1 can hide where the light sits (torus-phong's glossy bounce: a few pixels)
BRIGHTEST = 0.02
#: the ladder's rows: PRT of order 4, 256 rays, one bounce (diffuse scenes only: PRT transfers diffuse light);
#: 42 geodesic lights with 1024^2 shadow maps
PRT_LADDER = (4, 256, 1)
LIGHTS_LADDER = ("geodesic", 42, 1024)


def vct_ov(resolution: int, cascades: int, cones: int, interreflection: bool) -> dict:
    ov = {"realtime.occlusion": "vct", "realtime.vct.resolution": resolution, "realtime.vct.cascades": cascades,
          "realtime.vct.diffuse_cones": cones}
    if interreflection:
        ov["realtime.interreflection"] = "vct"
    return ov


def ladder_ov(spec: str) -> list[dict]:
    """The other techniques' rows of a scene: PRT with a bounce where it has diffuse light, the light array
    with shadow maps."""
    scene = scenes.load(spec)
    out = []
    if "diffuse" in scene.effects:
        out.append(prt_ov(*PRT_LADDER))
    out.append(lights_ov(scene, *LIGHTS_LADDER))
    return out


def configs(s: Settings, spec: str) -> list[dict]:
    vct_rows = [vct_ov(r, c, k, inter) for r, c, k in s.grid for inter in (False, True)]
    return [{}] + vct_rows + (ladder_ov(spec) if s.ladder else [])


def count_steps(settings: Settings) -> int:
    """Progress steps of `run`: per scene its spp ladder, one per row and the energy tables; the leak; the
    storage comparison's atriums x resolutions."""
    return (sum(len(configs(settings, spec)) + 2 for _, spec in SCENES) + 1
            + e10_voxel_storage.count_steps(settings.storage))


#: the configurations of every scene, in the order of the figures
MODES = ("direct (paper)", "occlusion", "occlusion + interreflection", "PRT + bounce", "light array + shadow maps")


def mode(r: ResultRow) -> str:
    t = r.techniques
    if t.get("diffuse") == "prt":
        return "PRT + bounce"
    if t.get("occlusion") == "shadow_maps":
        return "light array + shadow maps"
    if t.get("interreflection") == "vct":
        return "occlusion + interreflection"
    if t.get("occlusion") == "vct":
        return "occlusion"
    return "direct (paper)"


def setting(r: ResultRow) -> tuple[int, int, int] | None:
    ov = r.overrides
    if "realtime.vct.resolution" not in ov:
        return None
    return (ov["realtime.vct.resolution"], ov["realtime.vct.cascades"], ov["realtime.vct.diffuse_cones"])


def memory(spec: str, resolution: int, cascades: int, interreflection: bool) -> tuple[int, int]:
    """(bytes of the cascades, bytes of one 3D texture of the same finest voxel over the same extent); with
    interreflection a scene with glossy surfaces stores the deferred glossy read's gloss texture too (the
    frame's VoxelScene, vct.shared_voxels)."""
    objects = scenes.load(spec).objects
    lo, hi = vct.scene_bounds(objects)
    g = vct_math.cascades_for(lo, hi, resolution, cascades)
    glossy = interreflection and vct.has_glossy([vct.reflectance_of(o.material) for o in objects])
    per_voxel = vct.BYTES_PER_VOXEL + (vct.GLOSS_BYTES_PER_VOXEL if glossy else 0)
    return g.bytes_per_cascade(per_voxel) * cascades, g.single_texture_bytes(per_voxel)


def percent(x: float | None) -> str:
    """A share as a whole percentage, "-" where there is none."""
    return "-" if x is None else f"{100 * x:.0f} %"


def mib(b: float) -> str:
    return f"{b / 2**20:.1f}"


def linear_mean(img, mask) -> float:
    return float(img.rgb[mask].mean())


def area_render(scene, subpixels: int) -> Render:
    """The real-time image of `scene` with each pixel the mean of subpixels x subpixels point samples (rendered
    that much larger, box-reduced), as the path tracer's pixels are area means."""
    large = scene.with_overrides({"camera.width": scene.camera.width * subpixels,
                                  "camera.height": scene.camera.height * subpixels})
    return pixel_area_means(realtime.render(large), subpixels)


def energy_split(context: Context, spec: str, best: dict, s: Settings) -> dict:
    """Linear radiance means over the pixels covered in every image: the real-time occlusion-only and
    occlusion + interreflection images at each resolution of `s.energy_resolutions` (the best setting's
    cascades and cones) and, at the best setting, for each of `s.bounces`; the path tracer at max_depth 2
    (direct with occlusion), 2 + each bounce count, and full depth. The real-time images are area means over
    `s.energy_subpixels`^2 samples a pixel (`area_render`)."""
    base = {**context.base(), "realtime.timing_frames": 1, "realtime.warmup_frames": 0}
    scene = scenes.load(spec).with_overrides(base)
    occ_ov = {k: v for k, v in best.items() if k != "realtime.interreflection"}
    cascades, cones = occ_ov["realtime.vct.cascades"], occ_ov["realtime.vct.diffuse_cones"]
    renders, sub = {}, s.energy_subpixels
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        renders["direct"] = area_render(scene, sub)
        for res in s.energy_resolutions:
            ov = vct_ov(res, cascades, cones, False)
            renders[("occ", res)] = area_render(scene.with_overrides(ov), sub)
            renders[("all", res, 1)] = area_render(scene.with_overrides({**ov, "realtime.interreflection": "vct"}), sub)
        best_res = occ_ov["realtime.vct.resolution"]
        if ("occ", best_res) not in renders:
            renders[("occ", best_res)] = area_render(scene.with_overrides(occ_ov), sub)
        for b in s.bounces:
            if ("all", best_res, b) not in renders:
                renders[("all", best_res, b)] = area_render(scene.with_overrides(
                    {**occ_ov, "realtime.interreflection": "vct", "realtime.vct.bounces": b}), sub)
    depths = sorted({2} | {2 + b for b in s.bounces})
    refs = {d: reference.render(scene.with_overrides({"reference.integrator": "path", "reference.max_depth": d}))
            for d in depths}
    refs["full"] = reference.render(scene)
    mask = np.ones_like(refs["full"].mask)
    for r in [*renders.values(), *refs.values()]:
        mask = mask & r.mask
    path = {d: linear_mean(r, mask) for d, r in refs.items()}

    def ratio(a: float, b: float) -> float | None:
        return a / b if abs(b) > 1e-9 else None

    by_resolution = []
    for res in s.energy_resolutions:
        occ, inter = linear_mean(renders[("occ", res)], mask), linear_mean(renders[("all", res, 1)], mask)
        bounce = renders[("all", res, 1)].rgb - renders[("occ", res)].rgb
        by_resolution.append({"resolution": res, "occlusion": occ, "interreflection": inter,
                              "indirect_vct": inter - occ, "indirect_ratio": ratio(inter - occ, path[3] - path[2]),
                              "occluded_ratio": ratio(occ, path[2]),
                              "brightest_share": metrics.brightest_share(bounce, mask, BRIGHTEST)})
    occ_best = linear_mean(renders[("occ", best_res)], mask)
    by_bounces = []
    for b in s.bounces:
        inter = linear_mean(renders[("all", best_res, b)], mask)
        by_bounces.append({"bounces": b, "interreflection": inter, "indirect_vct": inter - occ_best,
                           "indirect_path": path[2 + b] - path[2],
                           "indirect_ratio": ratio(inter - occ_best, path[2 + b] - path[2])})
    one = next(x for x in by_bounces if x["bounces"] == 1)
    return {"direct": linear_mean(renders["direct"], mask), "occlusion": occ_best,
            "interreflection": one["interreflection"], "path": path, "cascades": cascades, "cones": cones,
            "by_resolution": by_resolution, "by_bounces": by_bounces,
            "indirect_vct": one["indirect_vct"], "indirect_path_one_bounce": path[3] - path[2],
            "indirect_path_all": path["full"] - path[2],
            "indirect_ratio": ratio(one["indirect_vct"], path[3] - path[2]),
            "occluded_ratio": ratio(occ_best, path[2]),
            "brightest_share_path": metrics.brightest_share(refs[3].rgb - refs[2].rgb, mask, BRIGHTEST)}


@dataclass(frozen=True)
class PosedObject:
    """A scene object's triangles in another pose, with its material: what VoxelScene reads of an object."""

    mesh: meshes.Mesh
    material: Material


def thin_wall_probes(scene, rotate_deg: tuple[float, float, float] = (0.0, 0.0, 0.0)
                     ) -> tuple[list[PosedObject], np.ndarray, np.ndarray, np.ndarray]:
    """The thin-wall scene (`scene`, builtin:thin-wall) turned about the origin (the centre of the box's floor)
    by rotation_xyz(rotate_deg): its objects, the 16 probe points on the ground inside the box, the 16 on a ring
    around it outside, and the ground's normal, all turned by the same rotation."""
    r = rotation_xyz(rotate_deg)
    posed = [PosedObject(o.mesh.transformed(1.0, rotate_deg, (0.0, 0.0, 0.0)), o.material) for o in scene.objects]
    xs = np.linspace(-0.3, 0.3, 4)
    inside = np.array([[x, 0.0, z] for x in xs for z in xs])
    ring = np.linspace(0.0, 2.0 * np.pi, 16, endpoint=False)
    outside = np.stack([1.2 * np.cos(ring), np.zeros_like(ring), 1.2 * np.sin(ring)], -1)
    return posed, inside @ r.T, outside @ r.T, r @ np.array([0.0, 1.0, 0.0])


def thin_wall_leak(resolutions: tuple[int, ...] = (32, 64), cascades: int = 1, offsets: int = 1,
                   rotate_deg: tuple[float, float, float] = (0.0, 0.0, 0.0)) -> list[dict]:
    """The thin-wall scene's leak: the irradiance the cones find (environment x visibility + gathered) on
    the ground inside the closed box (walls of zero thickness: one voxel once voxelised; exactly 0 in the
    path tracer) over the same on the ground outside it, both facing up (realtime.vct.VoxelScene.probe).
    At each resolution: the grid's own placement, then `offsets` - 1 placements shifted by the fractions
    k / offsets of (4.37, 2.9, 4.37) voxels (incommensurate with the box, so the walls fall at other places
    in the coarse texels): the leak at the own placement, the mean and the largest over all. `rotate_deg`
    turns the whole scene (thin_wall_probes): walls oblique to the grid's axes, the environment unturned."""
    ctx = get_context()
    scene = scenes.load("builtin:thin-wall")
    objects, inside, outside, up = thin_wall_probes(scene, rotate_deg)
    lo, hi = vct.scene_bounds(objects)
    env = filled_store(ctx, scene)
    _, M = env.read_sh()
    n4 = np.append(up, 1.0)
    sky = np.array([n4 @ M[c] @ n4 for c in range(3)])  # the unoccluded SH9 irradiance facing up
    out = []
    for res in resolutions:
        own = vct_math.cascades_for(lo, hi, res, cascades)
        leaks, first = [], None
        for k in range(offsets):
            shift = np.array([4.37, 2.9, 4.37]) * own.voxel_size * k / offsets
            grid = vct_math.Cascades(tuple(float(c) for c in np.asarray(own.centre) + shift), own.half_extent,
                                     res, cascades)
            vs = VoxelScene(ctx, objects, res, cascades, 6, 0.5, grid=grid)
            vs.update(None, env.sh_buffer)
            r_in = vs.probe(inside, np.tile(up, (len(inside), 1)))
            r_out = vs.probe(outside, np.tile(up, (len(outside), 1)))
            vs.release()
            e_in = (sky * r_in[:, 3:4] + r_in[:, :3]).mean()
            e_out = (sky * r_out[:, 3:4] + r_out[:, :3]).mean()
            leaks.append(float(e_in / max(e_out, 1e-12)))
            if first is None:
                first = {"inside": float(e_in), "outside": float(e_out), "visibility_inside": float(r_in[:, 3].mean()),
                         "visibility_outside": float(r_out[:, 3].mean())}
        out.append({"resolution": res, "cascades": cascades, "voxel": own.voxel_size, **first, "leak": leaks[0],
                    "leak_mean": float(np.mean(leaks)), "leak_max": float(np.max(leaks)), "placements": offsets,
                    "rotate_deg": tuple(float(a) for a in rotate_deg)})
    env.release()
    return out


def walls(rotate_deg: tuple[float, float, float]) -> str:
    """How a leak row's box stands to the grid: along its axes, or turned (degrees about x, y, z)."""
    if not any(rotate_deg):
        return "along the grid's axes"
    return "turned " + " / ".join(f"{a:g}" for a in rotate_deg) + " deg about x / y / z"


def run(context: Context, settings: Settings) -> Section:
    """E10's rows through `context.row` (resumable) and its section."""
    s = settings
    timing = {"realtime.timing_frames": s.frames, "realtime.warmup_frames": 1}
    per_scene: dict[str, tuple[list[ResultRow], list]] = {}
    energy: dict[str, dict] = {}
    for name, spec in SCENES:
        scene = scenes.load(spec).with_overrides(context.base())
        curve = convergence.curve(scene, max_spp=context.common.spp)
        context.progress()
        rows = [context.row(spec, {**timing, **c}, "E10", curve=curve) for c in configs(s, spec)]
        per_scene[name] = (rows, curve)
        b = best(rows, "occlusion + interreflection")
        energy[name] = energy_split(context, spec, b.overrides if b else vct_ov(64, 2, 6, True), s) | {
            "setting": setting(b) if b else None}
        context.progress()
    leak = [x for rot in s.leak_rotations for x in thin_wall_leak(s.leak_resolutions, offsets=s.leak_offsets,
                                                                  rotate_deg=rot)]
    context.progress()
    storage = e10_voxel_storage.run(context.out, s.storage, step=context.progress)
    storage_figure = e10_voxel_storage.FIGURE
    figure, heat = "figures/e10_vct.png", "figures/e10_heat.png"
    plot(per_scene, context.out / figure)
    plot_heat(per_scene, context.out, context.out / heat)
    header = ["scene", "mode", "resolution", "cascades", "cones", "unbiased PSNR dB", "frame ms", "voxelize ms",
              "mip ms", "trace ms", "voxel MiB", "single 3D texture MiB"]
    table = []
    for name, (rows, _) in per_scene.items():
        spec = dict(SCENES)[name]
        direct = next((r for r in rows if mode(r).startswith("direct")), None)
        d_draw = direct.realtime_ms.get("draw") if direct else None
        for r in rows:
            st = setting(r)
            mem = memory(spec, st[0], st[1], "interreflection" in mode(r)) if st else None
            draw = r.realtime_ms.get("draw")
            trace = None if (st is None or draw is None or d_draw is None) else draw - d_draw
            table.append([name, mode(r), *(map(str, st) if st else ("-", "-", "-")),
                          unbiased_cell(r), f2(frame_ms(r)),
                          f2(r.realtime_ms.get("voxelize")), f2(r.realtime_ms.get("mip")), f2(trace),
                          mib(mem[0]) if mem else "-", mib(mem[1]) if mem else "-"])
    e_header = ["scene", "best setting", "direct", "VCT occlusion", "VCT occl. + interr.", "path depth 2",
                "path depth 3", "path full", "indirect VCT / path one bounce", "VCT occlusion / path depth 2"]
    e_rows = [[name, "x".join(map(str, e["setting"])) if e["setting"] else "-", f4(e["direct"]), f4(e["occlusion"]),
               f4(e["interreflection"]), f4(e["path"][2]), f4(e["path"].get(3)), f4(e["path"]["full"]),
               f3(e["indirect_ratio"]), f3(e["occluded_ratio"])] for name, e in energy.items()]
    top = f"{100 * BRIGHTEST:g} %"
    r_header = ["scene", "resolution", "cascades", "cones", "VCT indirect (1 bounce)", "path one bounce",
                "indirect VCT / path", "VCT occlusion / path depth 2", f"VCT bounce in its brightest {top} of pixels",
                f"path bounce in its brightest {top}"]
    r_rows = [[name, str(x["resolution"]), str(e["cascades"]), str(e["cones"]), f4(x["indirect_vct"]),
               f4(e["indirect_path_one_bounce"]), f3(x["indirect_ratio"]), f3(x["occluded_ratio"]),
               percent(x["brightest_share"]), percent(e["brightest_share_path"])]
              for name, e in energy.items() for x in e["by_resolution"]]
    b_header = ["scene", "best setting", "bounces", "VCT indirect", "path indirect (depth 2 + bounces - depth 2)",
                "indirect VCT / path"]
    b_rows = [[name, "x".join(map(str, e["setting"])) if e["setting"] else "-", str(x["bounces"]),
               f4(x["indirect_vct"]), f4(x["indirect_path"]), f3(x["indirect_ratio"])]
              for name, e in energy.items() for x in e["by_bounces"]]
    l_header = ["walls", "resolution", "cascades", "voxel", "irradiance inside", "outside", "leak (inside / outside)",
                "leak mean over placements", "leak max over placements", "visibility inside", "visibility outside"]
    l_rows = [[walls(x["rotate_deg"]), str(x["resolution"]), str(x["cascades"]), f"{x['voxel']:.4f}",
               f4(x["inside"]), f4(x["outside"]),
               f"{100 * x['leak']:.2f} %", f"{100 * x['leak_mean']:.2f} %", f"{100 * x['leak_max']:.2f} %",
               f3(x["visibility_inside"]), f3(x["visibility_outside"])] for x in leak]
    findings = summarize(per_scene, energy, leak)
    note = ("Frame ms: medians over the timed frames of every per-frame part: the environment (`filter`), the "
            "voxelisation with the cone-traced injection (`voxelize`), the six-face mips (`mip`) and the shading "
            "pass (`draw`), llvmpipe on 2 shared cores. Trace ms: the shading pass's ms minus the same scene's "
            "direct-only pass (the cones run inside `draw`). Voxel MiB: six RGBA16F faces, the RGBA16F column "
            f"texture and six RGBA8 face normals ({vct.BYTES_PER_VOXEL} bytes a voxel; "
            f"{vct.BYTES_PER_VOXEL + vct.GLOSS_BYTES_PER_VOXEL} with the RGBA16F gloss texture of the deferred "
            "glossy read, six faces a voxel, with interreflection in scenes with a glossy surface) with their mip "
            "chains for every cascade, against one 3D texture with "
            "the finest voxel over the outermost "
            "extent. Mean radiances are linear, over the pixels covered in every image; path depth 2 is direct "
            "light with occlusion, depth 2 + k adds k bounces; VCT's k bounces are `[realtime.vct] bounces = k` "
            "(k - 1 gathered bounces re-injected into the voxels). The brightest 2 %: the share of each one-bounce "
            "image's light (VCT's occlusion + interreflection minus its occlusion, the path tracer's depth 3 minus "
            "depth 2, over the same pixels) in its own brightest 2 % of pixels, negative pixels (the noise of a "
            "difference of two renders) counted as 0, where the means above keep them. The leak: the irradiance "
            "the diffuse cones find on the ground inside a closed box with walls of zero thickness (one voxel once "
            "voxelised; the path tracer's is 0) over the irradiance on the ground outside it, at the grid's own "
            f"placement and over {s.leak_offsets} placements shifted by fractions of a voxel, with the box's walls "
            "along the grid's axes and with the whole scene turned so that every wall is oblique to them (the "
            "environment unturned). The ladder rows: "
            f"PRT of order {PRT_LADDER[0]}, {PRT_LADDER[1]} rays, {PRT_LADDER[2]} bounce (diffuse scenes), and "
            f"{LIGHTS_LADDER[1]} {LIGHTS_LADDER[0]} lights with {LIGHTS_LADDER[2]}^2 shadow maps.")
    md = ("\n".join(f"- {f}" for f in findings) + "\n\n" + report.md_table(header, table) + "\n\n"
          + report.md_table(e_header, e_rows) + "\n\n" + report.md_table(r_header, r_rows) + "\n\n"
          + report.md_table(b_header, b_rows) + "\n\n" + report.md_table(l_header, l_rows) + "\n\n" + note
          + "\n\n" + "\n".join(f"- {line}" for line in storage.lines) + "\n\n"
          + report.md_table(storage.header, storage.rows) + "\n\n"
          + report.md_table(storage.size_header, storage.size_rows))
    blocks = [report.bullets(findings), report.table(header, table), report.figure(figure, "E10"),
              report.figure(heat, "E10 heat maps"), report.table(e_header, e_rows), report.table(r_header, r_rows),
              report.table(b_header, b_rows), report.table(l_header, l_rows), report.paragraph(note),
              report.bullets(storage.lines), report.table(storage.header, storage.rows),
              report.table(storage.size_header, storage.size_rows), report.figure(storage_figure, "E10 voxel storage")]
    return Section(TITLE, blocks, md, [figure, heat, storage_figure])


def best(rows: list[ResultRow], which: str) -> ResultRow | None:
    """The best row (unbiased PSNR) of mode `which`."""
    return report.best_row(rows, lambda r: mode(r) == which)


def summarize(per_scene: dict, energy: dict, leak: list[dict]) -> list[str]:
    out = []
    for name, (rows, _) in per_scene.items():
        parts = []
        for which in MODES:
            b = best(rows, which)
            if b is not None:
                st = setting(b)
                at = f" at {st[0]}^3 x {st[1]} cascades, {st[2]} cones" if st else ""
                parts.append(f"{which} {b.psnr_unbiased:.2f} dB in {f2(frame_ms(b))} ms{at}")
        out.append(f"{name}: " + "; ".join(parts) + ".")
        e = energy.get(name)
        if e:
            out.append(f"{name}: indirect energy VCT / path one bounce = {f3(e['indirect_ratio'])} "
                       f"(VCT {e['indirect_vct']:.4f}, path {e['indirect_path_one_bounce']:.4f}, all bounces "
                       f"{e['indirect_path_all']:.4f}); VCT occlusion / path depth 2 = {f3(e['occluded_ratio'])}; "
                       "by resolution " + ", ".join(f"{x['resolution']}^3 {f3(x['indirect_ratio'])}"
                                                    for x in e["by_resolution"])
                       + "; by bounces " + ", ".join(f"{x['bounces']}: {f3(x['indirect_ratio'])}"
                                                      for x in e["by_bounces"])
                       + f"; the brightest {100 * BRIGHTEST:g} % of pixels hold "
                       + ", ".join(percent(x["brightest_share"]) for x in e["by_resolution"])
                       + f" of VCT's bounce by resolution, {percent(e['brightest_share_path'])} of the "
                       "path tracer's.")
    for x in leak:
        out.append(f"thin wall ({walls(x['rotate_deg'])}) at {x['resolution']}^3 (voxel {x['voxel']:.4f}): "
                   f"{100 * x['leak']:.2f} % of the lit "
                   f"side's irradiance leaks inside (mean {100 * x['leak_mean']:.2f} %, at most "
                   f"{100 * x['leak_max']:.2f} % over {x['placements']} grid placements; target at most 1 %).")
    return out


def plot(per_scene: dict, path) -> None:
    """Unbiased PSNR against frame ms per scene, one marker per mode, each VCT point labelled with its
    resolution/cascades/cones, the spp ladder."""
    plt = plots.pyplot()
    n = len(per_scene)
    fig, axes = plt.subplots(1, n, figsize=(5.2 * n, 4.4), squeeze=False)
    for ax, (name, (rows, curve)) in zip(axes.flat, per_scene.items(), strict=True):
        pts = plots.scatter_families(ax, rows, mode, markers="osD^v", order=MODES)
        for r in pts:
            st = setting(r)
            if st:
                ax.annotate(f"{st[0]}/{st[1]}/{st[2]}", (frame_ms(r), r.psnr_unbiased), fontsize=5)
        plots.finish_accuracy_time_axes(ax, curve, name)
    plots.save(fig, path)


def plot_heat(per_scene: dict, root, path) -> None:
    """Where VCT errs: the |realtime - reference| maps of direct only and each mode's best setting."""
    cells = []
    for name, (rows, _) in per_scene.items():
        line = []
        for which in MODES:
            r = best(rows, which)
            line.append((r, "" if r is None else f"{name}: {which}\n{r.psnr_unbiased:.1f} dB"))
        cells.append(line)
    plots.error_grid(cells, root, path)
