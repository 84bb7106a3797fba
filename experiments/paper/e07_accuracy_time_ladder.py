"""E7 of the paper suite: the accuracy-time ladder across real-time techniques.

For each scene (sphere-diffuse, sphere-phong at N = 10, 100, 1000, sphere-blend, sphere-sky with its
1e4 sun for very high dynamic range, and the sphere in glTF's metallic-roughness material, whose ladder is
the split sum's engine recipes) every technique
the scene can use, at its main parameter, is one point: `psnr_unbiased` (the PSNR a noise-free
reference would give, experiments.measure.metrics) against the frame's per-frame milliseconds (every
per-frame key + draw). The path tracer's own spp ladder (experiments.measure.convergence) is drawn on the
same axes, so `equal_quality_s` — the seconds Mitsuba needs to reach a technique's quality — and the
speed-up at equal quality (equal_quality_s / frame time) can be read off. Pareto fronts per scene.

Techniques from other installed packages (the entry-point group `iblcheck.techniques`) join the ladder
with the override points they declare (`plugin_points`), on the scenes of their effect: a diffuse
technique on sphere-diffuse, a glossy one on the sphere-phong scenes and sphere-blend.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

import scenes
from experiments.measure import convergence
from experiments.measure.results import ResultRow
from experiments.paper.context import Context
from experiments.publish import plots, report
from experiments.publish.plots import frame_ms
from experiments.publish.report import Section, f2
from realtime.engine.context import get_context
from realtime.engine.cube_seams import seam_residual, smooth_lobes
from realtime.engine.gpu import EnvironmentFilter
from realtime.engine.levels import level_of
from realtime.techniques.prefiltered.prefilter import PhongPrefilter
from scenes.environment import cubemap
from scenes.model import technique_registry

NUMBER = 7
TITLE = "E7 accuracy against time across techniques"


@dataclass(frozen=True)
class Settings:
    sh: tuple[tuple[int, str], ...]  # (order, window)
    irradiance: tuple[tuple[int, int], ...]  # (size, source_size)
    box_biases: tuple[float, ...]
    samples: tuple[int, ...]
    fis_biases: tuple[float, ...]  # extra rows at 64 samples: Filament's +1 level
    blend: tuple[tuple[dict, dict], ...]  # (diffuse overrides, glossy overrides)
    max_spp: int
    split_sum_sizes: tuple[int, ...] = ()  # Khronos' recipe at these chain sizes, beside each recipe's own


def sh_ov(order: int, window: str = "none") -> dict:
    return {"realtime.diffuse": "sh", "realtime.sh_order": order, "realtime.sh_window": window}


def irr_ov(size: int, source: int) -> dict:
    return {"realtime.diffuse": "irradiance_map", "realtime.irradiance_map.size": size,
            "realtime.irradiance_map.source_size": source}


def box_ov(bias: float = 0.0, mapping: str = "paper") -> dict:
    return {"realtime.glossy": "box", "realtime.lod_bias": bias, "realtime.lod_mapping": mapping}


def pre_ov(samples: int, bias: float = 0.0) -> dict:
    return {"realtime.glossy": "prefiltered", "realtime.prefiltered.samples": samples,
            "realtime.prefiltered.bias": bias}


_BLEND = ((sh_ov(2), box_ov()), (sh_ov(2), box_ov(0.0, "mcguire")), (sh_ov(4), box_ov(0.0, "mcguire")),
          (sh_ov(2), pre_ov(64)), (sh_ov(4), pre_ov(256)), (irr_ov(32, 32), pre_ov(64)),
          (irr_ov(32, 32), pre_ov(256)), (irr_ov(32, 32), box_ov(0.0, "mcguire")))
QUICK = Settings(sh=((2, "none"), (3, "none"), (4, "none"), (4, "hanning")), irradiance=((16, 16), (32, 32)),
                       box_biases=(0.0, 2.0, 4.0), samples=(16, 64, 256), fis_biases=(), blend=_BLEND[:6],
                       max_spp=1024, split_sum_sizes=(32,))
FULL = Settings(sh=((2, "none"), (2, "hanning"), (3, "none"), (3, "hanning"), (4, "none"), (4, "hanning")),
                      irradiance=((16, 16), (32, 32), (64, 32), (32, 64)),
                      box_biases=(0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0), samples=(16, 64, 256, 1024),
                      fis_biases=(1.0,), blend=_BLEND,
                      max_spp=4096, split_sum_sizes=(32, 64, 128))
EXPONENTS = (10.0, 100.0, 1000.0)
#: glTF's metallic-roughness material on E7's sphere: its ladder is the split sum's engine recipes
PBR_LABEL = "sphere-pbr (glTF, metallic 0.5, roughness 0.3)"
PBR_SPHERE = {"objects.0.material": {"type": "pbr", "base_color": [0.9, 0.64, 0.54], "metallic": 0.5,
                                     "roughness": 0.3},
              "realtime.glossy": "split_sum"}
SPLIT_SUM_RECIPES = ("khronos", "filament", "threejs", "babylon")


def scene_list() -> list[tuple[str, str, dict]]:
    """(label, spec, overrides) of E7's scenes."""
    out = [("sphere-diffuse", "builtin:sphere-diffuse", {})]
    out += [(f"sphere-phong N={n:g}", "builtin:sphere-phong", {"objects.*.material.exponent": n}) for n in EXPONENTS]
    out.append(("sphere-blend", "builtin:sphere-blend", {}))
    out.append(("sphere-sky (sun 1e4)", "builtin:sphere-sky", {}))  # a very high dynamic range map
    out.append((PBR_LABEL, "builtin:sphere-blend", PBR_SPHERE))  # glTF's material, the split sum's recipes
    return out


def scene_effect(label: str) -> str | None:
    """The effect whose plugin techniques run on E7's scene `label` (None: no plugin runs there)."""
    if label == "sphere-diffuse":
        return "diffuse"
    if label.startswith("sphere-phong") or label == "sphere-blend":
        return "glossy"
    return None


def plugin_points(declarations=None) -> list[tuple[str, dict]]:
    """(effect, overrides) of every ladder point of every technique that is not builtin, in the registry's
    order: `{"realtime.<effect>": name, **point}` for each point of its declared `ladder`.
    `declarations`: the registry's (scenes.model.technique_registry.declarations()) unless given."""
    if declarations is None:
        declarations = technique_registry.declarations()
    return [(d.effect, {f"realtime.{d.effect}": d.name, **point})
            for d in declarations if not d.builtin for point in d.ladder]


def configs_for(label: str, s: Settings, plugins: list[tuple[str, dict]] = ()) -> list[dict]:
    """The overrides of E7's rows on scene `label`: the builtin techniques' ladder, then the points of the
    plugin techniques of the scene's effect (`plugins`, from `plugin_points`)."""
    if label == "sphere-diffuse":
        builtin = [sh_ov(o, w) for o, w in s.sh] + [irr_ov(a, b) for a, b in s.irradiance]
    elif label == PBR_LABEL:
        # each recipe at its own chain size, and Khronos' at the chain sizes of a real-time budget; every
        # frame prefilters the whole chain, so fewer timed frames than the other rows
        few = {"realtime.timing_frames": 5, "realtime.warmup_frames": 1}
        builtin = ([{"realtime.split_sum.recipe": r, **few} for r in SPLIT_SUM_RECIPES]
                   + [{"realtime.split_sum.recipe": "khronos", "realtime.split_sum.size": n, **few}
                      for n in s.split_sum_sizes])
    elif label.startswith("sphere-phong"):
        builtin = ([box_ov(b) for b in s.box_biases] + [box_ov(0.0, "mcguire")] + [pre_ov(n) for n in s.samples]
                   + [pre_ov(64, b) for b in s.fis_biases])
    else:
        builtin = [{**d, **g} for d, g in s.blend]
    effect = scene_effect(label)
    return builtin + [dict(ov) for e, ov in plugins if e == effect]


def count_steps(settings: Settings) -> int:
    """Progress steps of `run`: per scene its spp ladder and one per row."""
    plugins = plugin_points()
    return sum(len(configs_for(label, settings, plugins)) + 1 for label, _, _ in scene_list())


def run(context: Context, settings: Settings) -> Section:
    """E7's rows through `context.row` (resumable) and its section."""
    s = settings
    plugins = plugin_points()
    per_scene: dict[str, tuple[list[ResultRow], list]] = {}
    for label, spec, ov in scene_list():
        scene = scenes.load(spec).with_overrides({**context.base(), **ov})
        curve = convergence.curve(scene, max_spp=s.max_spp)
        context.progress()
        rows = [context.row(spec, {**ov, **c}, "E7", curve=curve) for c in configs_for(label, s, plugins)]
        per_scene[label] = (rows, curve)
    table = []
    for label, (rows, _) in per_scene.items():
        for r in sorted(rows, key=lambda r: frame_ms(r) or 0.0):
            ms = frame_ms(r)
            speed = None if r.equal_quality_s is None or not ms else r.equal_quality_s / (ms / 1e3)
            table.append([label, r.technique_label, f2(r.psnr), report.unbiased_cell(r), f2(ms),
                          f2(r.realtime_ms.get("precompute")),
                          "-" if r.equal_quality_s is None else at_least(r) + f"{r.equal_quality_s:.3g}"
                          + (" (extrapolated)" if (r.equal_quality or "").startswith("extrapolated") else ""),
                          "-" if speed is None else f"{at_least(r)}{speed:,.3g}x"])
    figure = "figures/e7_ladder.png"
    plot(per_scene, context.out / figure)
    header = ["scene", "technique", "PSNR dB", "unbiased PSNR dB", "frame ms", "precompute ms",
              "path tracer s to equal quality", "speed-up at equal quality"]
    findings = summarize(per_scene)
    seam_header = ["face size", "box chain", *(f"prefiltered N = {n:g} (64 samples)" for n in SEAM_EXPONENTS)]
    seams = seam_rows()
    seam_note = ("Cube-edge seams on a smooth map (three wide lobes, realtime.engine.cube_seams.smooth_lobes): the "
                 "step across a face edge divided by the step one texel inward (1 = no seam). A box chain's "
                 "texels are averages of a distorted grid per face, a prefiltered chain's the lobe's value at "
                 "their own centres.")
    note = ("Frame ms: the median of every per-frame part (cube map + chain + SH = `filter`, the irradiance "
            "convolution, the lobe prefilter) plus the shading pass, with the map refiltered every frame. "
            "Unbiased PSNR removes the reference's own noise (half the mean squared difference of its two "
            "seeds) from the error; '(floor)' marks a value clamped at what the reference can resolve (the "
            "path tracer's time to match it is then a lower bound, '≥'). The path tracer's time to equal "
            "quality comes from the scene's own spp ladder (two seeds per rung, its noise floor as its "
            "PSNR), sampling time only; beyond the ladder it is extrapolated with the Monte Carlo law "
            "(+6.02 dB per 4x spp).")
    md = ("\n".join(f"- {f}" for f in findings) + "\n\n" + report.md_table(header, table) + "\n\n" + note
          + "\n\n" + report.md_table(seam_header, seams) + "\n\n" + seam_note)
    blocks = [report.bullets(findings), report.table(header, table), report.paragraph(note),
              report.figure(figure, "E7"), report.table(seam_header, seams),
              report.paragraph(seam_note)]  # data, rendered by the template with autoescape
    return Section(TITLE, blocks, md, [figure])


SEAM_FACES = (64, 32, 16, 8, 4)
SEAM_EXPONENTS = (10.0, 100.0)


def seam_rows(base_size: int = 256, samples: int = 64) -> list[list[str]]:
    """Cube-edge seams (realtime/engine/cube_seams.py: the step across a face edge over the step one texel
    inward, 1 = no seam) of the box chain and of prefiltered chains, per face size, on a smooth map.
    Users of prefiltering tools report seams that grow with blur; this measures them here."""
    ctx = get_context()
    # a smooth map of a few wide lobes (a real probe's own detail would swamp the ratio), as base faces
    f = EnvironmentFilter(ctx, np.zeros((2, 4, 3), np.float32), base_size)
    lobes, _ = smooth_lobes(cubemap.texel_directions(base_size))
    rgba = np.repeat(lobes[..., None], 4, axis=-1).astype("f4")
    for face in range(6):  # level 0 (TextureCube.write writes the base level), then the paper's box chain
        f.cube.write(face, np.ascontiguousarray(rgba[face]).tobytes())
    f.build_chain()
    chains = {n: PhongPrefilter(ctx, base_size, n, samples, 0.0) for n in SEAM_EXPONENTS}
    first = levels_of(base_size, SEAM_FACES[0])
    for p in chains.values():
        p.run(f.cube, first)
    out = []
    try:
        for face in SEAM_FACES:
            level = levels_of(base_size, face)
            cells = [f"{seam_residual(f.read_level(level))['ratio']:.3f}"]
            cells += [f"{seam_residual(p.read_level(level))['ratio']:.3f}" for p in chains.values()]
            out.append([str(face), *cells])
    finally:
        for p in chains.values():
            p.release()
        f.release()
    return out


def levels_of(base_size: int, face: int) -> int:
    return level_of(face, base_size)


def at_least(r: ResultRow) -> str:
    """'≥ ' when the unbiased PSNR sits at the reference's resolution: the real image may be better
    still, so the path tracer's time to match it is a lower bound."""
    return "≥ " if r.psnr_unbiased_clamped else ""


def family(r: ResultRow) -> str:
    """The technique family of a row without its parameter ('SH4', 'box McGuire', 'prefiltered'): one
    colour per family in the E7 plot (ResultRow.technique_label names the point itself)."""
    t = r.techniques
    parts = []
    if "diffuse" in r.effects:
        d = t.get("diffuse")
        parts.append(f"SH{t['sh_order']}" if d == "sh" else "irradiance map" if d == "irradiance_map" else d)
    if "glossy" in r.effects:
        g = t.get("glossy")
        parts.append(("box McGuire" if t.get("lod_mapping") == "mcguire" else "box") if g == "box" else g)
    return " + ".join(parts)


def plot(per_scene: dict, path) -> None:
    """Unbiased PSNR against frame ms per scene, one colour per technique family, the Pareto front and the
    path tracer's spp ladder."""
    fig, axes = plots.panel_grid(len(per_scene), 4.6, 4.0)
    for ax, (label, (rows, curve)) in zip(axes.flat, per_scene.items(), strict=False):
        pts = plots.scatter_families(ax, rows, family)
        if pts:
            t = np.array([frame_ms(r) for r in pts])
            p = np.array([r.psnr_unbiased for r in pts])
            front = plots.pareto_front(t, p)
            ax.plot(t[front], p[front], color="k", lw=1.0, drawstyle="steps-post", label="Pareto front")
        plots.finish_accuracy_time_axes(ax, curve, label)
        ax.set_xlim(0.5, 2e5)
    plots.save(fig, path)


def pareto_steps(rows: list[ResultRow]) -> list[ResultRow]:
    """The rows of the accuracy-time Pareto front (unbiased PSNR against frame ms), cheapest first."""
    t = np.array([frame_ms(r) for r in rows])
    p = np.array([r.psnr_unbiased for r in rows])
    return [rows[i] for i in plots.pareto_front(t, p)]


def summarize(per_scene: dict) -> list[str]:
    """A few sentences of what each step of accuracy costs, computed from the rows."""
    out = []
    for label, (rows, _) in per_scene.items():
        ok = [r for r in rows if r.psnr_unbiased is not None and frame_ms(r)]
        if not ok:
            continue
        best = max(ok, key=lambda r: r.psnr_unbiased)
        cheap = min(ok, key=frame_ms)
        line = (f"{label}: best {best.technique_label} at {best.psnr_unbiased:.2f} dB in {frame_ms(best):.1f} ms; "
                f"cheapest {cheap.technique_label} at {cheap.psnr_unbiased:.2f} dB in {frame_ms(cheap):.1f} ms")
        if best.equal_quality_s:
            line += (f"; the path tracer needs {'at least ' if best.psnr_unbiased_clamped else ''}"
                     f"{best.equal_quality_s:.3g} s for the best one's quality "
                     f"({best.equal_quality_s / (frame_ms(best) / 1e3):,.3g}x the frame time)")
        out.append(line + ".")
        steps = pareto_steps(ok)
        if len(steps) > 1:
            out.append(f"{label}, each step of the Pareto front: " + "; ".join(
                f"{b.technique_label} buys {b.psnr_unbiased - a.psnr_unbiased:+.2f} dB for "
                f"{frame_ms(b) - frame_ms(a):+.1f} ms" for a, b in zip(steps, steps[1:], strict=False)) + ".")
        by = {r.technique_label: r for r in ok}
        o2, o3 = by.get("SH order 2"), by.get("SH order 3")
        if o2 and o3:
            out.append(f"{label}: SH order 3 gives {o3.psnr_unbiased - o2.psnr_unbiased:+.3f} dB over order 2 "
                       f"(A_3 = 0: the odd band adds nothing to irradiance) for "
                       f"{frame_ms(o3) - frame_ms(o2):+.2f} ms.")
    return out
