"""E12 of the paper suite: shipped engines against the truth.

E11 measured each engine's split-sum recipe as iblcheck re-implements it. E12 asks the engines themselves:
the scene is exported (scenes/exchange/: glTF 2.0, the environment as a viewer's equirect .hdr, the sidecar)
and rendered by three.js and Babylon.js in headless Chromium (engines/web/, WebGL2 on SwiftShader) and by
Blender's Cycles (engines/cycles/), each through `realtime.renderer = "command"` (engines/command.py).

- E11's grid (roughness 0 ... 1 across, metallic 0, 0.5, 1 down) under E11's probes: every sphere of each
  engine's image scored against the noise-free quadrature of glTF's BRDF (as E11 scores the recipes), and
  against iblcheck's split sum with that engine's recipe (how well iblcheck models the engine: where the two
  agree, E11's attribution of the error to the recipe's parts is the engine's).
- one mesh (`builtin:pawn-pbr`) per engine against the path tracer (`psnr_unbiased`).
- the convention diagnosis (experiments/measure/diagnosis/) run on every engine image: it should find
  nothing; what it finds is a finding about the engine or about the export, and the section says which.
- engine name and version in every row (`gl_renderer`), and the frame times the engine reports (SwiftShader
  and Cycles run on the CPU: CPU times).

An engine that is not installed on the machine (no Chromium, no npm packages, no bpy) is left out with the
reason the bridge gave, never silently.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

import scenes
from engines.command import EngineRejected
from experiments.measure import metrics
from experiments.measure.diagnosis import diagnose
from experiments.measure.results import ResultRow
from experiments.paper import e11_split_sum as e11
from experiments.paper.context import Context
from experiments.publish import plots
from experiments.publish.report import Section, bullets, f2, figure, md_table, paragraph, table
from scenes import MissingCapability
from scenes.model.render import Render

NUMBER = 12
TITLE = "E12 shipped engines against the truth: three.js, Babylon.js and Cycles on glTF's material"
#: the engines and the E11 recipe that models each (None: a path tracer, no split sum)
ENGINES = {"threejs": "threejs", "babylon": "babylon", "cycles": None}
ENGINE_NAMES = {"threejs": "three.js", "babylon": "Babylon.js", "cycles": "Cycles"}
FIG_GRID = "figures/e12_engines.png"
FIG_IMAGES = "figures/e12_images.png"


@dataclass(frozen=True)
class Settings:
    e11: e11.Settings  # the grid, probes, quadrature and reference settings E11 uses (its rows are reused)
    probes: tuple[str, ...]
    diagnose: bool  # run the convention diagnosis on every engine image


QUICK = Settings(e11=e11.QUICK, probes=("uffizi",), diagnose=True)
FULL = Settings(e11=e11.FULL, probes=e11.FULL.probes, diagnose=True)


def engine_overrides(engine: str) -> dict:
    return {"realtime.renderer": "command", "realtime.command.engine": engine}


def count_steps(settings: Settings) -> int:
    """Per probe: the quadrature, and per engine its grid row, its recipe's grid row, its pawn row and its
    recipe's pawn row (the diagnosis' control)."""
    return len(settings.probes) * (1 + 4 * len(ENGINES))


@dataclass
class EngineResult:
    grid_rows: dict[str, ResultRow]  # probe -> the engine's grid row
    truth: dict[str, e11.SphereScores]  # probe -> per sphere against the truth (TRUTH_OF)
    model: dict[str, e11.SphereScores | None]  # probe -> per sphere against iblcheck's split sum of its recipe
    recipe: dict[str, e11.SphereScores | None]  # probe -> iblcheck's split sum of its recipe against the truth
    pawn_rows: dict[str, ResultRow]
    diagnoses: dict[str, list[str]]  # "grid uffizi" / "pawn uffizi" -> what the diagnosis found (empty: nothing)
    controls: dict[str, list[str]]  # the same on iblcheck's split sum of the engine's recipe (no convention error)
    images: dict[str, Render]  # probe -> the engine's grid image (for the figure)


#: what each engine is scored against per sphere: a real-time engine (no occlusion, like the split sum)
#: against the quadrature of the same BRDF, as E11 scores the recipes; Cycles, a path tracer that has the
#: neighbours' occlusion and light, against Mitsuba's path-traced reference of the same scene
TRUTH_OF = {"threejs": "quadrature", "babylon": "quadrature", "cycles": "Mitsuba"}
#: the diagnosis renders its references with at most this many samples per pixel (its threshold is tied to
#: the reference's noise, so fewer samples only make it more cautious)
DIAGNOSIS_SPP = 256


def run(context: Context, settings: Settings) -> Section:
    s, s11 = settings, settings.e11
    results: dict[str, EngineResult] = {}
    absent: dict[str, str] = {}
    exact_of: dict[str, tuple[scenes.Scene, Render, np.ndarray]] = {}
    for probe in s.probes:
        grid = e11.grid_overrides(s11, probe)
        scene = scenes.load(e11.GRID).with_overrides({**context.base(), **grid})
        exact, _ = e11.quadrature_of(scene, s11.subpixels)
        context.progress()
        exact_of[probe] = (scene, exact, e11.sphere_masks(scene))
    for engine, recipe in ENGINES.items():
        steps = StepCounter(context)
        try:
            results[engine] = run_engine(steps, s, engine, recipe, exact_of)
        except MissingCapability as exc:  # not installed here: absent, with the bridge's reason
            absent[engine] = f"absent from this run: {exc}" + (f"; {exc.hint}" if exc.hint else "")
        except EngineRejected as exc:  # installed, but it refused the scene or returned no usable image
            absent[engine] = f"failed: {exc}"
        for _ in range(4 * len(s.probes) - steps.count):
            context.progress()
    return section(context, s, results, absent, exact_of)


class StepCounter:
    """The context, counting the progress steps taken through it (an engine that fails part way leaves the
    rest of its steps to be taken by the caller)."""

    def __init__(self, context: Context):
        self.context, self.count = context, 0

    def row(self, *args, **kwargs) -> ResultRow:
        out = self.context.row(*args, **kwargs)  # one step, taken only when the row is there
        self.count += 1
        return out

    def progress(self) -> None:
        self.count += 1
        self.context.progress()

    def __getattr__(self, name: str):
        return getattr(self.context, name)


def pawn_overrides(s: Settings, probe: str) -> dict:
    return {"camera.width": s.e11.object_size, "camera.height": s.e11.object_size,
            "environment.map": f"builtin:{probe}"}


def run_engine(context: Context | StepCounter, s: Settings, engine: str, recipe: str | None, exact_of) -> EngineResult:
    out = EngineResult({}, {}, {}, {}, {}, {}, {}, {})
    for probe in s.probes:
        scene, exact, masks = exact_of[probe]
        grid = e11.grid_overrides(s.e11, probe)
        row = checked(context.row(e11.GRID, {**grid, **engine_overrides(engine)}, "E12"))
        sc, test = context.image_of(row)
        out.grid_rows[probe], out.images[probe] = row, test
        truth = exact if TRUTH_OF[engine] == "quadrature" else context.reference_of(sc)
        out.truth[probe] = e11.score_spheres(sc, test, truth, masks)
        pawn = checked(context.row(e11.OBJECT, {**pawn_overrides(s, probe), **engine_overrides(engine)}, "E12"))
        out.pawn_rows[probe] = pawn
        psc, ptest = context.image_of(pawn)
        if s.diagnose:
            out.diagnoses[f"grid {probe}"] = found(sc, test)
            out.diagnoses[f"pawn {probe}"] = found(psc, ptest)
        if recipe is None:
            out.model[probe] = out.recipe[probe] = None
            context.progress()
            context.progress()
            continue
        model_row = checked(context.row(e11.GRID, {**grid, **e11.recipe_overrides(s.e11, recipe, True)}, "E12"))
        msc, model = context.image_of(model_row)
        out.model[probe] = e11.score_spheres(sc, test, model, masks)
        out.recipe[probe] = e11.score_spheres(sc, model, exact, masks)
        control = checked(context.row(e11.OBJECT, {**pawn_overrides(s, probe),
                                                   **e11.recipe_overrides(s.e11, recipe, False)}, "E12"))
        if s.diagnose:
            out.controls[f"grid {probe}"] = found(msc, model)
            csc, ctest = context.image_of(control)
            out.controls[f"pawn {probe}"] = found(csc, ctest)
    return out


class RowFailed(RuntimeError):
    """A row whose reference (or real-time part) failed: the suite's error, not the engine's."""


def checked(row: ResultRow) -> ResultRow:
    if row.error:
        raise RowFailed(f"{row.scene}: {row.error}")
    return row


def found(scene: scenes.Scene, image: Render) -> list[str]:
    """The mistakes the convention diagnosis accepts on an engine image, in words (empty: none)."""
    scene = scene.with_overrides({"reference.spp": min(scene.reference.spp, DIAGNOSIS_SPP)})
    out = []
    for m in diagnose(scene, image.rgb).mistakes:
        value = "" if m.parameter is None else f" ({m.parameter:.3g})" if isinstance(m.parameter, float) \
            else f" ({m.parameter})"
        out.append(f"{m.name}{value}: +{m.gain_db:.2f} dB")
    return out


# --------------------------------------------------------------------------- the section


def _mean_db(scores: dict[str, e11.SphereScores | None]) -> np.ndarray | None:
    """(3, 6) mean over probes, or None."""
    vals = [v.psnr for v in scores.values() if v is not None]
    return np.mean(vals, axis=0) if vals else None


def section(context: Context, s: Settings, results: dict[str, EngineResult], absent: dict[str, str],
            exact_of) -> Section:
    rough_cols = [f"r = {r:g}" for r in e11.ROUGHNESS]
    header = ["engine (version)", "against", "metallic", *rough_cols, "mean", "frame ms", "precompute ms"]
    rows_out = []
    for engine, res in results.items():
        any_row = next(iter(res.grid_rows.values()))
        name = f"{ENGINE_NAMES[engine]} ({any_row.gl_renderer or '?'})"
        frame, pre = any_row.realtime_ms.get("total"), any_row.realtime_ms.get("precompute")
        for against, scores in ((TRUTH_OF[engine], res.truth), (f"iblcheck's {ENGINES[engine]} recipe", res.model)):
            db = _mean_db(scores)
            if db is None:
                continue
            for j, m in enumerate(e11.METALLIC):
                first = j == 0 and against == TRUTH_OF[engine]
                rows_out.append([name if first else "", against if j == 0 else "", f"{m:g}", *(f2(v) for v in db[j]),
                                 f2(float(db[j].mean())), f2(frame) if first else "", f2(pre) if first else ""])
    pawn_header = ["engine", "probe", "PSNR dB", "unbiased PSNR dB", "FLIP", "frame ms"]
    pawn_out = [[ENGINE_NAMES[e], p, f2(r.psnr), f2(r.psnr_unbiased), f"{r.flip:.3f}" if r.flip is not None else "-",
                 f2(r.realtime_ms.get("total"))] for e, res in results.items() for p, r in res.pawn_rows.items()]
    diag_header = ["engine", "image", "the diagnosis finds", "on iblcheck's split sum of the engine's recipe (control)"]
    diag_out = [[ENGINE_NAMES[e], where, "; ".join(f) if f else "nothing",
                 ("; ".join(res.controls[where]) or "nothing") if where in res.controls else "-"]
                for e, res in results.items() for where, f in res.diagnoses.items()]
    findings = summarize(s, results, absent)
    if results:
        plot_engines(results, context.out / FIG_GRID)
        plot_images(s, results, exact_of, context.out / FIG_IMAGES)
    note = ("Per sphere: PSNR of the tone-mapped pixels against the truth (the real-time engines against the "
            "quadrature of glTF's BRDF, which has no occlusion either, as E11 scores the recipes; Cycles, a path "
            "tracer, against Mitsuba's reference), or against iblcheck's split sum with the recipe it reads from the "
            "engine's code (E11), silhouettes left out; mean over the probes " + ", ".join(s.probes) + ". The "
            f"diagnosis renders its references at {DIAGNOSIS_SPP} spp at most; its control is the same diagnosis on "
            "iblcheck's own split sum of the engine's recipe, whose conventions are right by construction: a "
            "mistake found on both is the approximation's error looking like a convention, not the engine's. "
            "Frame ms: the engine's own median frame time as it reports "
            "it (three.js and Babylon.js on SwiftShader, Cycles' whole render: CPU times).")
    md = "\n".join(f"- {f}" for f in findings) + "\n\n"
    blocks = [bullets(findings)]
    if results:
        md += md_table(header, rows_out) + "\n\n" + note + "\n\n" + md_table(pawn_header, pawn_out)
        blocks += [table(header, rows_out), paragraph(note), figure(FIG_GRID, "E12 engines"),
                   figure(FIG_IMAGES, "E12 images"), table(pawn_header, pawn_out)]
    if diag_out:
        md += "\n\n" + md_table(diag_header, diag_out)
        blocks.append(table(diag_header, diag_out))
    return Section(TITLE, blocks, md, [FIG_GRID, FIG_IMAGES] if results else [])


def summarize(s: Settings, results: dict[str, EngineResult], absent: dict[str, str]) -> list[str]:
    out = []
    for engine, reason in absent.items():
        out.append(f"{ENGINE_NAMES[engine]} is {reason}")
    for engine, res in results.items():
        truth = _mean_db(res.truth)
        line = f"{ENGINE_NAMES[engine]}: {truth.mean():.2f} dB against {TRUTH_OF[engine]} on average"
        model, recipe = _mean_db(res.model), _mean_db(res.recipe)
        if model is not None and recipe is not None:
            line += (f"; iblcheck's {ENGINES[engine]} recipe scores {recipe.mean():.2f} dB, and the engine's image is "
                     f"{model.mean():.2f} dB from iblcheck's model of it")
        worst = np.unravel_index(np.argmin(truth), truth.shape)
        line += (f"; its worst sphere is metallic {e11.METALLIC[worst[0]]:g}, roughness "
                 f"{e11.ROUGHNESS[worst[1]]:g} ({truth[worst]:.2f} dB)")
        flagged = {k: v for k, v in res.diagnoses.items() if v}
        line += (". The diagnosis finds nothing on its images" if not flagged else
                 ". The diagnosis finds " + "; ".join(f"{k}: {', '.join(v)}" for k, v in flagged.items()))
        also = [k for k in flagged if res.controls.get(k)]
        if also:
            line += (f" (on {', '.join(also)} it finds a mistake on iblcheck's own split sum of the engine's recipe "
                     "too: the approximation's error, which looks like a convention there, not the engine's)")
        out.append(line + ".")
    return out


def plot_engines(results: dict[str, EngineResult], path) -> None:
    """dB against roughness, one panel per metallic: each engine against the truth (solid) and iblcheck's
    split sum of its recipe against the truth (dashed)."""
    plt = plots.pyplot()
    fig, axes = plt.subplots(1, len(e11.METALLIC), figsize=(4 * len(e11.METALLIC), 3.4), squeeze=False)
    for j, m in enumerate(e11.METALLIC):
        ax = axes[0, j]
        for engine, res in results.items():
            line, = ax.plot(e11.ROUGHNESS, _mean_db(res.truth)[j], "o-", ms=3,
                            label=f"{ENGINE_NAMES[engine]} vs {TRUTH_OF[engine]}")
            recipe = _mean_db(res.recipe)
            if recipe is not None:
                ax.plot(e11.ROUGHNESS, recipe[j], "--", color=line.get_color(), lw=1,
                        label=f"iblcheck, {ENGINES[engine]} recipe")
        ax.set_title(f"metallic {m:g}")
        ax.set_xlabel("roughness")
        ax.set_ylabel("PSNR vs the truth (dB)")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=6)
    plots.save(fig, path)


def plot_images(s: Settings, results: dict[str, EngineResult], exact_of, path) -> None:
    """The grid under the first probe: the truth, then each engine's image (tone-mapped alike)."""
    probe = s.probes[0]
    scene, exact, _ = exact_of[probe]
    strip = [("quadrature of glTF's BRDF (the truth)", metrics.display(scene, exact.rgb))]
    strip += [(ENGINE_NAMES[e], metrics.display(scene, r.images[probe].rgb)) for e, r in results.items()]
    plt = plots.pyplot()
    h, w = strip[0][1].shape[:2]
    fig, axes = plt.subplots(len(strip), 1, figsize=(7, len(strip) * 7 * h / w + 0.3 * len(strip)), squeeze=False)
    for ax, (title, rgb) in zip(axes[:, 0], strip, strict=True):
        ax.imshow(np.clip(rgb, 0.0, 1.0), interpolation="nearest")
        ax.set_title(f"{title}, {probe}", fontsize=8)
        ax.axis("off")
    plots.save(fig, path)
