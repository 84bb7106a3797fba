"""E8 of the paper suite: what shadows and bounces cost in real time.

On scenes that call for occlusion and interreflection (bowl-diffuse, teapot-blend, sphere-on-plane),
against the same path-traced references, with `psnr_unbiased` (the PSNR a noise-free reference would
give) against the frame's per-frame milliseconds and the precomputation's seconds:

(a) the paper: no occlusion, no interreflection;
(b) the light array (realtime/techniques/lights/lights.py), geodesic and median-cut, 4 ... 642 lights, without and with
    shadow maps (realtime/techniques/shadow_maps/shadow_maps.py; 256 and 1024 texels, as far as the 1 GiB map budget
    allows);
    a blend material takes both lobes from the array, so the maps shadow its highlights too;
(c) precomputed radiance transfer (realtime/techniques/prt/prt.py): SH order 2/3/4 x rays 64/256/1024 x bounces 0/1/2;
(d) sharp shadows (e08_sharp_shadows): SH PRT of orders 2..8 against wavelet PRT and shadow maps under a broad probe,
    a probe of small bright sources and the sun sky.

The light array's error is split in two with references of the array itself (Mitsuba, the same N
directional emitters): the array against the environment (discretisation: both path-traced, each
one's noise removed), and the real-time shadows against exact visibility (the array's direct-lighting
reference). The path tracer's own spp ladder is drawn on the same axes.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

import scenes
from experiments.measure import convergence, metrics
from experiments.measure.results import ResultRow
from experiments.paper import e08_sharp_shadows as sharp
from experiments.paper.context import Context
from experiments.paper.e08_overrides import fits, lights_label, lights_ov, prt_ov
from experiments.publish import plots, report
from experiments.publish.plots import frame_ms
from experiments.publish.report import Section, f2, f3, unbiased_cell
from groundtruth.pathtracer import reference
from realtime.techniques.prt.prt import transfer_objects
from realtime.techniques.prt.prt_transfer import cached_transfer
from realtime.techniques.prt.settings import effective_settings

NUMBER = 8
TITLE = "E8 what shadows and bounces cost"

SCENES = (("bowl-diffuse", "builtin:bowl-diffuse"), ("teapot-blend", "builtin:teapot-blend"),
          ("sphere-on-plane", "builtin:sphere-on-plane"))


@dataclass(frozen=True)
class Settings:
    geodesic: tuple[int, ...]
    median_cut: tuple[int, ...]
    shadow_sizes: tuple[int, ...]
    prt_orders: tuple[int, ...]
    prt_rays: tuple[int, ...]
    prt_bounces: tuple[int, ...]
    split_arrays: tuple[tuple[str, int], ...]  # arrays whose error is split with references of the array
    frames: int  # timed frames per configuration (medians); shadow maps of 642 lights take ~1 s a frame here
    max_spp: int
    sharp: sharp.SharpSettings  # the sharp-shadow part (e08_sharp_shadows)


QUICK = Settings(geodesic=(12, 42, 162), median_cut=(16, 64), shadow_sizes=(256,), prt_orders=(2, 4),
                   prt_rays=(64, 256), prt_bounces=(0, 1), split_arrays=(("geodesic", 42), ("median_cut", 64)),
                   frames=3, max_spp=256, sharp=sharp.QUICK)
FULL = Settings(geodesic=(4, 12, 42, 162, 642), median_cut=(4, 16, 64, 256), shadow_sizes=(256, 1024),
                  prt_orders=(2, 3, 4), prt_rays=(64, 256, 1024), prt_bounces=(0, 1, 2),
                  split_arrays=(("geodesic", 42), ("geodesic", 162), ("geodesic", 642), ("median_cut", 64),
                                ("median_cut", 256)),
                  frames=5, max_spp=1024, sharp=sharp.FULL)


def configs(scene, s: Settings) -> list[dict]:
    out: list[dict] = [{}]
    arrays = [("geodesic", n) for n in s.geodesic] + [("median_cut", n) for n in s.median_cut]
    for placement, n in arrays:
        out.append(lights_ov(scene, placement, n))
        out += [lights_ov(scene, placement, n, size) for size in s.shadow_sizes if fits(n, size)]
    out += [{"realtime.diffuse": "prt", "realtime.prt.order": o} for o in s.prt_orders]  # unshadowed
    out += [prt_ov(o, r, b) for o in s.prt_orders for r in s.prt_rays for b in s.prt_bounces]
    return out


def count_steps(settings: Settings) -> int:
    """Progress steps of `run`: per scene its spp ladder, one per row, two per split array; the sharp-shadow part's."""
    s = settings
    per = [len(configs(scenes.load(spec), s)) + 1 + 2 * len(s.split_arrays) for _, spec in SCENES]
    return sum(per) + sharp.count_steps(s.sharp)


def family(r: ResultRow) -> str:
    """One curve per technique family in the E8 figure."""
    t = r.techniques
    if t.get("diffuse") == "prt":
        if t.get("occlusion") != "prt":
            return "PRT unshadowed"
        return f"PRT shadowed, {t.get('prt', {}).get('bounces', 0)} bounces"
    if "lights" in (t.get("diffuse"), t.get("glossy")):
        lights = t.get("lights", {})
        placement = "geodesic" if lights.get("placement") == "geodesic" else "median cut"
        if t.get("occlusion") == "shadow_maps":
            return f"lights {placement} + shadow maps {lights.get('shadow_map_size')}"
        return f"lights {placement}"
    return "paper (no occlusion)"


def label(r: ResultRow) -> str:
    t = r.techniques
    if t.get("diffuse") == "prt":
        p = t.get("prt", {})
        if t.get("occlusion") != "prt":
            return f"PRT order {p.get('order')} unshadowed"
        return f"PRT order {p.get('order')}, {p.get('rays')} rays, {p.get('bounces', 0)} bounces"
    return lights_label(t) or "paper"


def precompute_s(r: ResultRow) -> float | None:
    """The precomputation's seconds: PRT's transfer (its compute time, also when read from the cache),
    otherwise the techniques' own `precompute` (the light array's regions, a shader's compile)."""
    if r.extra.get("prt_seconds") is not None:
        return r.extra["prt_seconds"]
    ms = r.realtime_ms.get("precompute")
    return None if ms is None else ms / 1e3


def discretisation(scene, placement: str, count: int, cluster=None) -> dict:
    """The array against the environment, both path-traced: unbiased PSNR with both references' own noise
    (half the mean squared difference of their two seeds) removed from the MSE. With a Dask `cluster`
    (experiments/runs/dask_cluster.py) the four references are its tasks."""
    pair = reference.render_pair if cluster is None else cluster.references
    env_a, env_b = pair(scene)
    array_scene = scene.with_overrides({**lights_ov(scene, placement, count), "reference.lighting": "light_array"})
    arr_a, arr_b = pair(array_scene)
    mask = env_a.mask & env_b.mask & arr_a.mask & arr_b.mask
    d = [metrics.display(scene, x.rgb)[mask] for x in (env_a, env_b, arr_a, arr_b)]
    mse = float(np.mean((d[2] - d[0]) ** 2))
    noise = 0.5 * float(np.mean((d[0] - d[1]) ** 2)) + 0.5 * float(np.mean((d[2] - d[3]) ** 2))
    floor = 0.5 * float(np.mean((d[0] - d[1]) ** 2))
    unbiased = max(mse - noise, floor * 1e-2, 1e-12)
    return {"placement": placement, "count": count, "psnr": 10 * np.log10(1.0 / max(mse, 1e-12)),
            "psnr_unbiased": float(10 * np.log10(1.0 / unbiased)), "clamped": mse - noise <= floor * 1e-2,
            "mean_ratio": float(d[2].mean() / max(d[0].mean(), 1e-12))}


def run(context: Context, settings: Settings) -> Section:
    """E8's rows through `context.row` (resumable) and its section."""
    s = settings
    timing = {"realtime.timing_frames": s.frames, "realtime.warmup_frames": 1}
    per_scene: dict[str, tuple[list[ResultRow], list]] = {}
    splits: list[list[str]] = []
    for name, spec in SCENES:
        scene = scenes.load(spec).with_overrides(context.base())
        curve = convergence.curve(scene, max_spp=s.max_spp)
        context.progress()
        rows = [with_prt_seconds(context, context.row(spec, {**timing, **c}, "E8", curve=curve))
                for c in configs(scene, s)]
        per_scene[name] = (rows, curve)
        for placement, count in s.split_arrays:
            d = discretisation(scene, placement, count, context.cluster)
            context.progress()
            size = max(z for z in s.shadow_sizes if fits(count, z))
            exact = context.row(spec, {**timing, **lights_ov(scene, placement, count, size),
                                     "reference.lighting": "light_array", "reference.integrator": "direct"}, "E8")
            splits.append([name, f"{count} {placement.replace('_', ' ')}", f2(d["psnr_unbiased"])
                           + (" (floor)" if d["clamped"] else ""), f"{d['mean_ratio']:.3f}",
                           unbiased_cell(exact),
                           f"{size}"])
    figure, heat = "figures/e8_occlusion.png", "figures/e8_heat.png"
    plot(per_scene, context.out / figure)
    plot_heat(per_scene, context.out, context.out / heat)
    header = ["scene", "technique", "unbiased PSNR dB", "SSIM", "frame ms", "shadow ms", "precompute s",
              "not simulated"]
    table = []
    for name, (rows, _) in per_scene.items():
        for r in sorted(rows, key=lambda r: (family(r), frame_ms(r) or 0.0)):
            table.append([name, label(r), unbiased_cell(r),
                          f3(r.ssim), f2(frame_ms(r)), f2(r.realtime_ms.get("shadow")), f2(precompute_s(r)),
                          ", ".join(r.unsimulated_effects) or "-"])
    split_header = ["scene", "light array", "array vs environment: unbiased PSNR dB (discretisation)",
                    "array / environment mean", "shadow maps vs exact visibility: unbiased PSNR dB", "map size"]
    findings = summarize(per_scene, splits)
    note = ("Frame ms: the median over the timed frames of every per-frame part (the environment's cube map, "
            "chain and SH projection = `filter`; the light array's powers = `lights`; the shadow maps = "
            "`shadow`) plus the shading pass, llvmpipe on this machine's 2 cores. Precompute s: PRT's transfer "
            "(Embree visibility rays and the bounce gathering, its compute time even when read from the "
            "cache), otherwise the techniques' one-off set-up. Unbiased PSNR removes the reference's own noise. "
            "The split: 'array vs environment' compares Mitsuba's image of the N directional lights with its "
            "image of the map (both path-traced, each one's noise removed): what the discretisation costs even "
            "with exact shadows and bounces; 'shadow maps vs exact visibility' compares the real-time image "
            "with shadow maps with Mitsuba's direct lighting from the same array: what the maps' resolution, "
            "filtering and bias cost.")
    sharp_blocks, sharp_md, sharp_figures = sharp.section(context, s.sharp)
    md = ("\n".join(f"- {f}" for f in findings) + "\n\n" + report.md_table(header, table) + "\n\n"
          + report.md_table(split_header, splits) + "\n\n" + note + "\n\n" + sharp_md)
    blocks = [report.bullets(findings), report.table(header, table), report.figure(figure, "E8"),
              report.figure(heat, "E8 heat maps"), report.table(split_header, splits), report.paragraph(note),
              *sharp_blocks]
    return Section(TITLE, blocks, md, [figure, heat, *sharp_figures])


def with_prt_seconds(context: Context, row: ResultRow) -> ResultRow:
    """The transfer's compute seconds (from the PRT cache entry, also when the row read it from there)."""
    if row.techniques.get("diffuse") != "prt" or "prt_seconds" in row.extra:
        return row
    scene = scenes.load(row.spec).with_overrides(row.overrides)
    s = effective_settings(scene)
    _, info = cached_transfer(transfer_objects(scene), s.order, s.rays, s.bounces, s.shadowed)
    row = replace(row, extra={**row.extra, "prt_seconds": info.get("compute_seconds", info.get("seconds")),
                              "prt_vertices": info.get("vertices"), "prt_rays_traced": info.get("rays_traced")})
    context.replace_row(row)
    return row


def best(rows: list[ResultRow], fam_prefix: str) -> ResultRow | None:
    """The best row (unbiased PSNR) of the families starting with `fam_prefix`."""
    return report.best_row(rows, lambda r: family(r).startswith(fam_prefix))


def summarize(per_scene: dict, splits: list[list[str]]) -> list[str]:
    out = []
    for name, (rows, _) in per_scene.items():
        paper = next((r for r in rows if family(r).startswith("paper")), None)
        parts = []
        for prefix, what in (("lights", "light array"), ("lights geodesic + shadow", "geodesic array + shadow maps"),
                             ("lights median cut + shadow", "median-cut array + shadow maps"), ("PRT", "PRT")):
            b = best(rows, prefix)
            if b is not None:
                parts.append(f"{what}: best {label(b)} at {b.psnr_unbiased:.2f} dB, {f2(frame_ms(b))} ms a frame, "
                             f"{f2(precompute_s(b))} s precompute")
        if paper is not None and paper.psnr_unbiased is not None:
            out.append(f"{name}: the paper (no occlusion) {paper.psnr_unbiased:.2f} dB in {f2(frame_ms(paper))} ms; "
                       + "; ".join(parts) + ".")
        for n in (42, 642):
            a = next((r for r in rows if family(r) == "lights geodesic" and r.techniques["lights"]["count"] == n), None)
            if a is not None and paper is not None and a.psnr_unbiased is not None:
                out.append(f"{name}: {n} geodesic lights without shadows {a.psnr_unbiased:.2f} dB "
                           f"({a.psnr_unbiased - paper.psnr_unbiased:+.2f} dB against the paper's SH9 + box chain).")
    for row in splits:
        out.append(f"{row[0]}, {row[1]} lights: the array itself is {row[2]} dB from the environment "
                   f"(mean ratio {row[3]}); shadow maps ({row[5]}) are {row[4]} dB from the array's exact visibility.")
    out += seed_claims(per_scene, splits)
    return out


def seed_claims(per_scene: dict, splits: list[list[str]]) -> list[str]:
    """The seed's "about 42 lights are enough" and Debevec's "64 median-cut lights come close on a cathedral
    probe", checked: an array is enough where its own discretisation error (array against environment, exact
    shadows and bounces on both sides) is well below the error of the best real-time image of the scene, so
    that it is not what limits the result (3 dB margin: half the error)."""
    out = []
    for name, (rows, _) in per_scene.items():
        ok = [r for r in rows if r.psnr_unbiased is not None]
        if not ok:
            continue
        top = max(ok, key=lambda r: r.psnr_unbiased)
        for split in (x for x in splits if x[0] == name and x[1] in ("42 geodesic", "64 median cut")):
            value = float(split[2].split()[0])
            floor = " (at the references' resolution)" if "floor" in split[2] else ""
            verdict = ("enough: its discretisation is not what limits this scene" if value >= top.psnr_unbiased + 3.0
                       else "not enough: the array's own discretisation is as large as, or larger than, the error "
                       "of the best real-time image")
            out.append(f"{name}: {split[1]} lights are {verdict} ({value:.2f} dB{floor} from the environment, against "
                       f"{top.psnr_unbiased:.2f} dB for the best real-time image, {label(top)}).")
    return out


def plot(per_scene: dict, path) -> None:
    """Unbiased PSNR against frame ms per scene, one marker per technique family, the spp ladder."""
    plt = plots.pyplot()
    n = len(per_scene)
    fig, axes = plt.subplots(1, n, figsize=(5.2 * n, 4.4), squeeze=False)
    for ax, (name, (rows, curve)) in zip(axes.flat, per_scene.items(), strict=True):
        plots.scatter_families(ax, rows, family, markers="osD^v<>pP*Xh", size=18)
        plots.finish_accuracy_time_axes(ax, curve, name, legend_size=5.5)
    plots.save(fig, path)


def plot_heat(per_scene: dict, root, path) -> None:
    """Where each technique errs: the |realtime - reference| maps of the paper and of each family's best."""
    columns = (("paper", "paper"), ("lights", "light array (best)"), ("PRT", "PRT (best)"))
    cells = []
    for name, (rows, _) in per_scene.items():
        line = []
        for prefix, title in columns:
            r = best(rows, prefix)
            line.append((r, "" if r is None else f"{name}: {title}\n{label(r)}, {r.psnr_unbiased:.1f} dB"))
        cells.append(line)
    plots.error_grid(cells, root, path)
