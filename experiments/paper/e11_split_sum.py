"""E11 of the paper suite: the anatomy of split-sum error on glTF's metallic-roughness material.

Every shipped engine lights glTF's GGX material from an environment with Karis' split sum, each with
its own recipe (realtime/techniques/split_sum/recipes.py). E11 measures how far each recipe is from
the exact integral of the same BRDF, where, and why:

- the recipes side by side: a grid of spheres (roughness 0 ... 1 across, metallic 0, 0.5, 1 down;
  `builtin:spheres-pbr-grid`) under several probes, one of very high dynamic range (ennis, 1.9e3 between
  its brightest texel and its median). Each sphere is scored on its own pixels against the noise-free
  quadrature of the same BRDF (groundtruth/exact/quadrature.py), which ignores the neighbours' occlusion
  exactly as the split sum does, so the score is the approximation's error alone; the whole image also
  gets the usual row against the path tracer (`psnr_unbiased`). Frame and precompute milliseconds per
  recipe (llvmpipe: CPU times).
- the error attributed: on Khronos' recipe, one part at a time is swapped for its exact counterpart
  (many more prefilter samples; a float32 DFG table of many samples; one chain level prefiltered per
  roughness instead of a roughness <-> mip mapping; an irradiance map instead of SH9 for the Lambert
  term; single scattering instead of the multiple-scattering compensation), and the dB each swap gains
  is the dB that part costs. With every part exact, what remains is the split sum's own factorisation
  (n = v = r and the product of two integrals).
- the white furnace: under a constant environment of radiance 1, the energy a metal of base_color 1
  reflects against roughness, for the quadrature, the split sum with and without multiscatter, and the
  single-scattering directional albedo E(mu) integrated independently (groundtruth/exact/gltf_brdf.py).
- a non-convex object (`builtin:pawn-pbr`) per recipe against the path tracer.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

import scenes
from experiments.measure import metrics
from experiments.measure.results import ResultRow
from experiments.paper.context import Context
from experiments.publish import plots
from experiments.publish.report import Section, bullets, f2, figure, md_table, paragraph, table
from groundtruth.exact import gltf_brdf, quadrature, raycast
from scenes.model.render import Render
from scenes.model.scene import Scene

NUMBER = 11
TITLE = "E11 split-sum IBL of the glTF material: each engine's recipe against the exact integral"
GRID = "builtin:spheres-pbr-grid"
OBJECT = "builtin:pawn-pbr"
#: the grid scene's columns (roughness, left to right) and rows (metallic, top to bottom)
ROUGHNESS = (0.0, 0.1, 0.25, 0.5, 0.75, 1.0)
METALLIC = (0.0, 0.5, 1.0)
RECIPES = ("khronos", "filament", "threejs", "babylon")
BASELINE = "khronos"
FURNACE = {"environment.map": "builtin:constant", "objects.*.material.base_color": [1.0, 1.0, 1.0]}
#: recipes whose mean scores are closer than this are called tied (a tenth of a dB is no visible difference)
TIE_DB = 0.1
FIG_RECIPES = "figures/e11_recipes.png"
FIG_PARTS = "figures/e11_parts.png"
FIG_FURNACE = "figures/e11_furnace.png"


@dataclass(frozen=True)
class Settings:
    height: int  # the grid image's height in pixels (its width is twice that)
    object_size: int  # the pawn's image size
    probes: tuple[str, ...]  # builtin probes
    chain_size: int | None  # the prefiltered chain's base size for every row (None: each recipe's own)
    frames: int  # timed frames per recipe row (each frame prefilters the whole chain)
    subpixels: int  # the quadrature's sub-pixel rays per axis
    exact_samples: int  # the prefilter's sample count standing for the exact convolution
    exact_lut: tuple[int, int]  # (size, samples) of the float32 DFG table standing for the exact one
    grid_spp: int  # the grid's path-traced reference (its whole-image row; the spheres are scored on the quadrature)


QUICK = Settings(height=64, object_size=64, probes=("uffizi", "ennis", "pisa"), chain_size=32, frames=2,
                 subpixels=2, exact_samples=4096, exact_lut=(128, 1024), grid_spp=128)
FULL = Settings(height=128, object_size=128, probes=("uffizi", "ennis", "pisa"), chain_size=None, frames=5,
                subpixels=3, exact_samples=4096, exact_lut=(512, 4096), grid_spp=256)


def parts(s: Settings) -> tuple[tuple[str, dict], ...]:
    """(name, overrides) of each part of the baseline recipe swapped for its exact counterpart."""
    return (
        (f"prefilter samples ({s.exact_samples})", {"realtime.split_sum.samples": s.exact_samples}),
        (f"DFG table ({s.exact_lut[0]}², {s.exact_lut[1]} samples, float32)",
         {"realtime.split_sum.lut_size": s.exact_lut[0], "realtime.split_sum.lut_samples": s.exact_lut[1],
          "realtime.split_sum.lut_precision": "f32"}),
        ("roughness ↔ mip (a level per roughness)", {"realtime.split_sum.lod_mapping": "per_material"}),
        ("Lambert term (irradiance map for SH9)", {"realtime.diffuse": "irradiance_map",
                                                   "realtime.irradiance_map.size": 32,
                                                   "realtime.irradiance_map.source_size": 64}),
        ("single scattering (no multiscatter)", {"realtime.split_sum.multiscatter": "none"}),
    )


def all_exact(s: Settings) -> dict:
    out: dict = {}
    for _, ov in parts(s):
        out.update(ov)
    return out


def grid_overrides(s: Settings, probe: str) -> dict:
    return {"camera.width": 2 * s.height, "camera.height": s.height, "environment.map": f"builtin:{probe}",
            "reference.spp": s.grid_spp}


def recipe_overrides(s: Settings, recipe: str, timed: bool) -> dict:
    """The recipe at the settings' chain size; `timed`: its frames timed, else one untimed frame."""
    ov: dict = {"realtime.split_sum.recipe": recipe}
    if s.chain_size is not None:
        ov["realtime.split_sum.size"] = s.chain_size
    frames = {"realtime.timing_frames": s.frames, "realtime.warmup_frames": 1} if timed else \
        {"realtime.timing_frames": 1, "realtime.warmup_frames": 0}
    return {**ov, **frames}


def count_steps(settings: Settings) -> int:
    """Progress steps of `run`: the rows, and one per quadrature."""
    per_probe = len(RECIPES) + len(parts(settings)) + 1 + len(RECIPES)  # grid recipes, swaps, all exact, pawn
    return len(settings.probes) * (per_probe + 1) + 2 + 1  # + the furnace's two rows and its quadrature


# --------------------------------------------------------------------------- per-sphere scores


@dataclass(frozen=True)
class SphereScores:
    """Per grid sphere (metallic index, roughness index): PSNR and mean FLIP against the quadrature, and
    the mean radiance of the sphere's pixels (the furnace's energy)."""

    psnr: np.ndarray  # (3, 6)
    flip: np.ndarray  # (3, 6)
    energy: np.ndarray  # (3, 6), mean over RGB


def sphere_masks(scene: Scene) -> np.ndarray:
    """(18, H, W) bool: each grid sphere's pixels (its object id at the pixel centre), eroded by a pixel so
    that silhouettes, where the two renderers' coverage differs, are not scored."""
    hits = raycast.cast(scene, 1)
    ids = hits.object_id[..., 0]
    return np.stack([metrics.common_mask(ids == i, ids == i) for i in range(len(scene.objects))])


def score_spheres(scene: Scene, test: Render, exact: Render, masks: np.ndarray) -> SphereScores:
    disp_t, disp_e = metrics.display(scene, test.rgb), metrics.display(scene, exact.rgb)
    flip_map = metrics.flip_map(disp_t, disp_e)
    shape = (len(METALLIC), len(ROUGHNESS))
    psnr, flip, energy = np.zeros(shape), np.zeros(shape), np.zeros(shape)
    for i, m in enumerate(masks):
        j, k = divmod(i, len(ROUGHNESS))
        psnr[j, k] = metrics.psnr(disp_t, disp_e, m)
        flip[j, k] = float(flip_map[m].mean())
        energy[j, k] = float(test.rgb[m].mean())
    return SphereScores(psnr, flip, energy)


def predicted_energy(scene: Scene, masks: np.ndarray) -> np.ndarray:
    """(6,): the metal row's mean single-scattering directional albedo E(mu) over each sphere's pixels, mu
    the pixel centre's n.v: what a metal of base_color 1 reflects under a constant environment of 1."""
    hits = raycast.cast(scene, 1)
    mu = np.clip(-(hits.normal[..., 0, :] * hits.direction[..., 0, :]).sum(-1), 0.0, 1.0)
    row = METALLIC.index(1.0)
    out = np.zeros(len(ROUGHNESS))
    for k, r in enumerate(ROUGHNESS):
        m = masks[row * len(ROUGHNESS) + k]
        out[k] = float(np.mean(gltf_brdf.directional_albedo(mu[m], r)))
    return out


# --------------------------------------------------------------------------- the experiment


def run(context: Context, settings: Settings) -> Section:
    """E11's rows through `context.row` (resumable), the per-sphere scores and the section."""
    s = settings
    recipe_scores: dict[tuple[str, str], SphereScores] = {}
    recipe_rows: dict[tuple[str, str], ResultRow] = {}
    part_scores: dict[tuple[str, str], SphereScores] = {}
    pawn_rows: dict[tuple[str, str], ResultRow] = {}
    quadrature_s: dict[str, float] = {}
    for probe in s.probes:
        grid = grid_overrides(s, probe)
        scene = scenes.load(GRID).with_overrides({**context.base(), **grid})
        exact, seconds = quadrature_of(scene, s.subpixels)
        quadrature_s[probe] = seconds
        context.progress()
        masks = sphere_masks(scene)

        def scored(ov: dict, scene=scene, exact=exact, masks=masks, grid=grid) -> tuple[ResultRow, SphereScores]:
            row = context.row(GRID, {**grid, **ov}, "E11")
            sc, test = context.image_of(row)
            return row, score_spheres(sc, test, exact, masks)

        for recipe in RECIPES:
            recipe_rows[(probe, recipe)], recipe_scores[(probe, recipe)] = scored(recipe_overrides(s, recipe, True))
        base = recipe_overrides(s, BASELINE, False)
        for name, ov in parts(s):
            part_scores[(probe, name)] = scored({**base, **ov})[1]
        part_scores[(probe, "all exact")] = scored({**base, **all_exact(s)})[1]
        for recipe in RECIPES:
            pawn_rows[(probe, recipe)] = context.row(
                OBJECT, {"camera.width": s.object_size, "camera.height": s.object_size,
                         "environment.map": f"builtin:{probe}", **recipe_overrides(s, recipe, False)}, "E11")
    furnace = run_furnace(context, s)
    return section(context, s, recipe_scores, recipe_rows, part_scores, pawn_rows, furnace, quadrature_s)


def quadrature_of(scene: Scene, subpixels: int) -> tuple[Render, float]:
    """The noise-free quadrature of the grid (no occlusion, like the split sum) and its seconds."""
    t0 = time.perf_counter()
    out = quadrature.render(scene, subpixels)
    return out, time.perf_counter() - t0


@dataclass(frozen=True)
class Furnace:
    exact: np.ndarray  # (6,) the quadrature's energy of the metal row
    predicted: np.ndarray  # (6,) mean E(mu), integrated independently
    single: np.ndarray  # (6,) split sum without multiscatter
    multi: np.ndarray  # (6,) split sum with multiscatter


def run_furnace(context: Context, s: Settings) -> Furnace:
    grid = {**grid_overrides(s, "uffizi"), **FURNACE}
    scene = scenes.load(GRID).with_overrides({**context.base(), **grid})
    exact, _ = quadrature_of(scene, s.subpixels)
    context.progress()
    masks = sphere_masks(scene)
    row = METALLIC.index(1.0)
    out = {}
    for multiscatter in ("none", "fdez_aguera"):
        ov = {**grid, **recipe_overrides(s, BASELINE, False), "realtime.split_sum.multiscatter": multiscatter}
        r = context.row(GRID, ov, "E11")
        sc, test = context.image_of(r)
        out[multiscatter] = score_spheres(sc, test, exact, masks).energy[row]
    exact_energy = score_spheres(scene, exact, exact, masks).energy[row]
    return Furnace(exact_energy, predicted_energy(scene, masks), out["none"], out["fdez_aguera"])


# --------------------------------------------------------------------------- the section


def section(context: Context, s: Settings, recipe_scores, recipe_rows, part_scores, pawn_rows, furnace: Furnace,
            quadrature_s: dict[str, float]) -> Section:
    rough_cols = [f"r = {r:g}" for r in ROUGHNESS]
    header = ["probe", "recipe", "metallic", *rough_cols, "mean FLIP", "frame ms", "precompute ms"]
    rows_out = []
    for probe in s.probes:
        for recipe in RECIPES:
            sc, row = recipe_scores[(probe, recipe)], recipe_rows[(probe, recipe)]
            for j, m in enumerate(METALLIC):
                rows_out.append([probe, recipe, f"{m:g}", *(f2(v) for v in sc.psnr[j]), f"{sc.flip[j].mean():.3f}",
                                 f2(plots.frame_ms(row)) if j == 0 else "", f2(row.realtime_ms.get("precompute"))
                                 if j == 0 else ""])
    names = [n for n, _ in parts(s)]
    part_header = ["part swapped for its exact counterpart", *rough_cols, "mean"]
    part_out = []
    for name in names:
        gain = np.mean([part_scores[(p, name)].psnr - recipe_scores[(p, BASELINE)].psnr for p in s.probes],
                       axis=(0, 1))
        part_out.append([name, *(f"{g:+.2f}" for g in gain), f"{gain.mean():+.2f}"])
    remaining = np.mean([part_scores[(p, "all exact")].psnr for p in s.probes], axis=(0, 1))
    part_out.append(["all of them exact: what remains is n = v = r (dB, not a gain)",
                     *(f2(v) for v in remaining), f2(remaining.mean())])
    furnace_header = ["roughness", "quadrature", "E(mu) integrated independently", "split sum, single scattering",
                      "split sum + multiscatter"]
    furnace_out = [[f"{r:g}", f"{furnace.exact[k]:.4f}", f"{furnace.predicted[k]:.4f}", f"{furnace.single[k]:.4f}",
                    f"{furnace.multi[k]:.4f}"] for k, r in enumerate(ROUGHNESS)]
    pawn_header = ["probe", "recipe", "PSNR dB", "unbiased PSNR dB", "FLIP", "precompute ms"]
    pawn_out = [[p, rc, f2(r.psnr), f2(r.psnr_unbiased), f"{r.flip:.3f}" if r.flip is not None else "-",
                 f2(r.realtime_ms.get("precompute"))] for (p, rc), r in pawn_rows.items()]
    findings = summarize(s, recipe_scores, part_scores, names, furnace)
    plot_recipes(s, recipe_scores, context.out / FIG_RECIPES)
    plot_parts(s, part_scores, recipe_scores, names, context.out / FIG_PARTS)
    plot_furnace(furnace, context.out / FIG_FURNACE)
    chain = "each recipe's own chain size" if s.chain_size is None else f"every chain at {s.chain_size}² (quick)"
    note = (f"Per sphere: PSNR of the tone-mapped pixels against the quadrature of the same BRDF ({s.subpixels}² "
            f"sub-pixel rays; {', '.join(f'{p} {t:.0f} s' for p, t in quadrature_s.items())}), silhouettes left "
            f"out; {chain}. Frame ms: the median of {s.frames} frames, each prefiltering the whole chain on the "
            "GPU; precompute: the DFG table, once. All milliseconds are llvmpipe's, i.e. CPU times. Parts: the dB "
            f"each swap gains on {BASELINE}'s recipe, mean over metallic and probes.")
    md = ("\n".join(f"- {f}" for f in findings) + "\n\n" + md_table(header, rows_out) + "\n\n" + note + "\n\n"
          + md_table(part_header, part_out) + "\n\n" + md_table(furnace_header, furnace_out) + "\n\n"
          + md_table(pawn_header, pawn_out))
    blocks = [bullets(findings), table(header, rows_out), paragraph(note), figure(FIG_RECIPES, "E11 recipes"),
              table(part_header, part_out), figure(FIG_PARTS, "E11 parts"), table(furnace_header, furnace_out),
              figure(FIG_FURNACE, "E11 furnace"), table(pawn_header, pawn_out)]
    return Section(TITLE, blocks, md, [FIG_RECIPES, FIG_PARTS, FIG_FURNACE])


def summarize(s: Settings, recipe_scores, part_scores, names: list[str], furnace: Furnace) -> list[str]:
    out = []
    mean_db = {rc: np.mean([recipe_scores[(p, rc)].psnr for p in s.probes]) for rc in RECIPES}
    ranked = sorted(mean_db, key=mean_db.get, reverse=True)
    tied = [rc for rc in ranked if mean_db[ranked[0]] - mean_db[rc] < TIE_DB]
    verdict = (f"{tied[0]} is closest to the exact integral on average" if len(tied) == 1 else
               f"{', '.join(tied)} tie within {TIE_DB:g} dB")
    out.append("Mean dB over every sphere and probe: " + ", ".join(f"{rc} {v:.2f}" for rc, v in mean_db.items())
               + f"; {verdict}.")
    for k, r in enumerate(ROUGHNESS):
        per = {rc: np.mean([recipe_scores[(p, rc)].psnr[:, k] for p in s.probes]) for rc in RECIPES}
        top = max(per, key=per.get)
        out.append(f"roughness {r:g}: best {top} ({per[top]:.2f} dB), worst {min(per, key=per.get)} "
                   f"({min(per.values()):.2f} dB)")
    gains = {n: float(np.mean([part_scores[(p, n)].psnr - recipe_scores[(p, BASELINE)].psnr for p in s.probes]))
             for n in names}
    worst = max(gains, key=gains.get)
    out.append(f"On {BASELINE}'s recipe the costliest part is {worst} ({gains[worst]:+.2f} dB when made exact).")
    k1 = ROUGHNESS.index(1.0)
    out.append(f"White furnace at roughness 1: the quadrature reflects {furnace.exact[k1]:.3f}, E(mu) predicts "
               f"{furnace.predicted[k1]:.3f}; the split sum {furnace.single[k1]:.3f} without and "
               f"{furnace.multi[k1]:.3f} with multiscatter (which restores energy the specification's "
               "single-scattering BRDF does not have).")
    return out


def plot_recipes(s: Settings, recipe_scores, path) -> None:
    """dB against roughness, one panel per metallic, one line per recipe (mean over probes)."""
    plt = plots.pyplot()
    fig, axes = plt.subplots(1, len(METALLIC), figsize=(4 * len(METALLIC), 3.4), squeeze=False)
    for j, m in enumerate(METALLIC):
        ax = axes[0, j]
        for rc in RECIPES:
            ax.plot(ROUGHNESS, np.mean([recipe_scores[(p, rc)].psnr[j] for p in s.probes], axis=0), "o-", ms=3,
                    label=rc)
        ax.set_title(f"metallic {m:g}")
        ax.set_xlabel("roughness")
        ax.set_ylabel("PSNR vs exact (dB)")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
    plots.save(fig, path)


def plot_parts(s: Settings, part_scores, recipe_scores, names: list[str], path) -> None:
    """dB each part costs against roughness (mean over metallic and probes)."""
    plt = plots.pyplot()
    fig, ax = plt.subplots(figsize=(6.5, 3.6))
    for n in names:
        gain = np.mean([part_scores[(p, n)].psnr - recipe_scores[(p, BASELINE)].psnr for p in s.probes], axis=(0, 1))
        ax.plot(ROUGHNESS, gain, "o-", ms=3, label=n)
    ax.axhline(0.0, color="grey", lw=0.8)
    ax.set_xlabel("roughness")
    ax.set_ylabel(f"dB gained over {BASELINE} when exact")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=6)
    plots.save(fig, path)


def plot_furnace(furnace: Furnace, path) -> None:
    plt = plots.pyplot()
    fig, ax = plt.subplots(figsize=(5.5, 3.6))
    ax.plot(ROUGHNESS, furnace.exact, "o-", label="quadrature (exact, single scattering)")
    ax.plot(ROUGHNESS, furnace.predicted, "k:", label="E(mu), integrated independently")
    ax.plot(ROUGHNESS, furnace.single, "s--", label="split sum")
    ax.plot(ROUGHNESS, furnace.multi, "^--", label="split sum + multiscatter")
    ax.set_xlabel("roughness")
    ax.set_ylabel("reflected energy (constant environment 1)")
    ax.set_ylim(0.0, 1.1)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7)
    plots.save(fig, path)
