"""`iblcheck paper`: the paper-style experiment suite on builtin scenes (the main job).

    E1 diffuse    SH9 from face sizes 8 ... 256: against the reference, against brute-force
                  irradiance convolution (the quadrature), and SH9's own irradiance error; times.
    E2 glossy     LOD-bias sweeps for N in {10, 50, 200, 1000} at several face sizes; the best bias
                  per (N, face size) next to McGuire's formula and the PSNR each reaches.
    E3 Fresnel    blends for f0 in {0.02, 0.04, 0.5, 1.0}: error against the viewing angle.
    E4 cost       frame time by effect set and face size, the map turning (refiltered) every frame.
    E5 reference  spp against noise floor and seconds.
    E7 ladder     accuracy against time across real-time techniques (SH orders, irradiance maps,
                  box vs lobe-prefiltered chains) with the path tracer's spp ladder on the same axes
                  (experiments/paper/e07_accuracy_time_ladder.py).
    E9 storage    environment parameterizations at equal texel budgets: cube, dual paraboloid, sphere
                  map; sampling rates, where the error goes, the sphere map's view dependence,
                  per-vertex against per-pixel reflection (experiments/paper/e09_parameterizations.py).
    E8 occlusion  what shadows and bounces cost: the light array without and with shadow maps, PRT orders,
                  rays and bounces on bowl-diffuse, teapot-blend and sphere-on-plane, the array's error split
                  into discretisation and shadows (experiments/paper/e08_occlusion.py).
    E10 interreflection  cascaded voxel cone tracing on cornell-open, bowl-diffuse and torus-phong: direct only,
                  + occlusion, + interreflection over resolution x cascades x cones; voxel memory against one
                  3D texture; the indirect energy against the path tracer's one bounce; the thin-wall leak
                  (experiments/paper/e10_voxel_cone_tracing.py).
    E6 stability  every hard case (bright suns and SH windows, extreme exponents and sizes, broken
                  inputs, odd geometry, determinism) with what happened (experiments/paper/e06_stability.py).

Everything lands in OUT (default reports/paper): results.jsonl (every compared configuration),
experiments.json (the tables), figures/*.png, index.html and summary.md. `--quick` uses smaller
images, fewer samples and a coarser grid (under 5 minutes here from a cold cache).
"""

from __future__ import annotations

import json
import math
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from experiments.measure import metrics
from experiments.measure.results import RESULTS, ResultRow, folder_lock, store_in
from experiments.publish import plots
from experiments.publish.report import Section, figure, md_table, paragraph, table
from experiments.runs.sweep import row_id, run_row, with_equal_quality


@dataclass(frozen=True)
class Settings:
    size: int
    spp: int
    frames: int
    e1_faces: tuple[int, ...]
    e2_faces: tuple[int, ...]
    e2_biases: tuple[float, ...]
    e4_faces: tuple[int, ...]
    e5_spps: tuple[int, ...]


QUICK = Settings(size=96, spp=256, frames=10, e1_faces=(8, 16, 32, 64, 128), e2_faces=(32, 128),
                 e2_biases=(-1.0, 0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0), e4_faces=(8, 64, 256),
                 e5_spps=(16, 64, 256))
FULL = Settings(size=192, spp=1024, frames=30, e1_faces=(8, 16, 32, 64, 128, 256), e2_faces=(16, 32, 64, 128, 256),
                e2_biases=tuple(np.arange(-1.0, 7.01, 0.5).round(2).tolist()), e4_faces=(8, 16, 32, 64, 128, 256),
                e5_spps=(16, 64, 256, 1024, 4096))
TITLE = "iblcheck paper suite: Gu et al. 2006 against Mitsuba 3"
EXPONENTS = (10.0, 50.0, 200.0, 1000.0)
F0S = (0.02, 0.04, 0.5, 1.0)


def f2(x) -> str:
    return "-" if x is None else f"{x:.2f}"


class Suite:
    def __init__(self, out: Path, settings: Settings, progress, cluster=None):
        self.out, self.s, self.progress = out, settings, progress
        self.cluster = cluster  # experiments.runs.dask_cluster.Cluster: references as Dask tasks (None: here)
        self.store = store_in(out)
        self.done: dict[str, ResultRow] = {r.id: r for r in self.store.read()}
        self.used: list[str] = []
        self.reused = 0  # rows found in results.jsonl from an interrupted or earlier run
        (out / "figures").mkdir(parents=True, exist_ok=True)

    def base(self) -> dict:
        return {"camera.width": self.s.size, "camera.height": self.s.size, "reference.spp": self.s.spp,
                "realtime.timing_frames": self.s.frames, "realtime.warmup_frames": 3}

    def row(self, spec: str, overrides: dict, experiment: str, curve=None) -> ResultRow:
        """One compared configuration, resumable through results.jsonl."""
        ov = {**self.base(), **overrides}
        rid = row_id(spec, ov)
        if rid not in self.done:
            refs = None
            if self.cluster is not None:  # both seeds at once on the workers; frames timed here
                import scenes

                refs = self.cluster.references(scenes.load(spec).with_overrides(ov))
            self.done[rid] = run_row(self.out, spec, ov, experiment, convergence_curve=curve, references=refs)
            self.store.append(self.done[rid])
        elif rid not in self.used:
            self.reused += 1
        if curve is not None and self.done[rid].equal_quality is None:
            # the same configuration measured by another experiment (rows are keyed by content): add
            # the path tracer's time to its quality from this curve, without rendering it again
            self.done[rid] = with_equal_quality(self.done[rid], curve)
            self.store.rewrite(list(self.done.values()))
        if rid not in self.used:
            self.used.append(rid)
        self.progress()
        return self.done[rid]

    def quadrature(self, scene):
        """(the noise-free quadrature Render of `scene`, its seconds): a Dask task with a cluster (timed
        on the worker that ran it), else computed here."""
        if self.cluster is not None:
            return self.cluster.quadrature(scene)
        from groundtruth.exact import quadrature

        t0 = time.perf_counter()
        return quadrature.render(scene), time.perf_counter() - t0

    def prefetch(self, items: list[tuple[str, dict]], quadratures: tuple = ()) -> None:
        """With a cluster: submit the references of these (spec, overrides) now, so that they render in
        parallel; `row` then finds them (a miss costs parallelism, never correctness). On a host shared
        with the workers, wait for them before any frame is timed."""
        if self.cluster is None:
            return
        import scenes

        for spec, ov in items:
            self.cluster.submit_references(scenes.load(spec).with_overrides({**self.base(), **ov}))
        for spec in quadratures:
            self.cluster.submit_quadrature(scenes.load(spec).with_overrides(self.base()))
        if self.cluster.quiet_timing:
            self.cluster.wait_idle()

    def keep_only_used(self) -> None:
        """Rewrite results.jsonl with this run's rows only (a quick run after a full one, or the reverse,
        must not mix the two in one report); atomic, like every write of the file."""
        self.store.rewrite([self.done[i] for i in self.used])

    # ----------------------------------------------------------------------------- E1
    def e1(self) -> Section:
        import scenes
        from groundtruth.exact import quadrature
        from realtime.engine import sh

        spec = "builtin:sphere-diffuse"
        scene = scenes.load(spec).with_overrides(self.base())
        brute, brute_s = self.quadrature(scene)
        env = scene.environment.radiance()
        rng = np.random.default_rng(0)
        normals = rng.normal(size=(4000, 3))
        normals /= np.linalg.norm(normals, axis=1, keepdims=True)
        t0 = time.perf_counter()
        exact = math.pi * quadrature.irradiance(quadrature.cell_grid(env, quadrature.DIFFUSE_WIDTH), normals)
        conv_ms = (time.perf_counter() - t0) * 1e3 / len(normals)
        rows, rows_out = [], []
        for s in self.s.e1_faces:
            r = self.row(spec, {"realtime.face_size": s}, "E1")
            _, test = self.image_of(r)
            e_sh = sh.irradiance_from_sh(np.asarray(test.meta["sh_coeffs"]), normals)
            sh_err = float(np.sqrt(np.mean((e_sh - exact) ** 2)) / np.sqrt(np.mean(exact**2)))
            mask = metrics.common_mask(test.mask, brute.mask)
            vs_brute = metrics.psnr(metrics.display(scene, test.rgb), metrics.display(scene, brute.rgb), mask)
            rows.append((r, sh_err, vs_brute))
            rows_out.append([s, f2(r.psnr), f2(r.noise_floor_psnr), f2(vs_brute), f"{100 * sh_err:.3f}%",
                          f2(r.realtime_ms["filter"]), f2(r.realtime_ms["draw"])])
        header = ["face size", "PSNR vs reference", "noise floor", "PSNR vs brute force", "SH9 irradiance rel. RMS",
                  "filter ms", "draw ms"]
        plt = plots.pyplot()
        fig, ax = plt.subplots(1, 2, figsize=(9, 3.6))
        faces = [r.face_size for r, _, _ in rows]
        ax[0].plot(faces, [r.psnr for r, _, _ in rows], "o-", label="vs reference")
        ax[0].plot(faces, [b for _, _, b in rows], "s--", label="vs brute-force convolution")
        ax[0].axhline(rows[0][0].noise_floor_psnr, color="grey", lw=0.8, ls=":", label="reference noise floor")
        ax[0].set_xscale("log", base=2)
        ax[0].set_xlabel("face size")
        ax[0].set_ylabel("PSNR (dB)")
        ax[0].legend(fontsize=8)
        ax[1].plot(faces, [100 * e for _, e, _ in rows], "o-")
        ax[1].set_xscale("log", base=2)
        ax[1].set_xlabel("face size")
        ax[1].set_ylabel("SH9 irradiance error vs exact (% RMS)")
        for a in ax:
            a.grid(alpha=0.3, which="both")
        plots.save(fig, self.out / "figures/e1_diffuse.png")
        note = (f"Brute-force irradiance convolution (quadrature over a {quadrature.DIFFUSE_WIDTH}-wide cell grid, "
                f"numpy on the CPU): {brute_s:.1f} s for the whole {self.s.size}x{self.s.size} image, "
                f"{conv_ms:.3f} ms per normal; SH9 replaces it by a 4x4 matrix per channel.")
        md = md_table(header, rows_out) + "\n\n" + note
        return Section("E1 diffuse: SH9 irradiance by face size", [table(header, rows_out), paragraph(note),
                       figure("figures/e1_diffuse.png", "E1")], md, ["figures/e1_diffuse.png"])

    @staticmethod
    def image_of(row: ResultRow):
        """(scene, real-time Render) of a compared row, re-rendered with one frame: rows keep metrics,
        not images, and the image does not depend on how many frames were timed."""
        import realtime
        import scenes

        sc = scenes.load(row.spec).with_overrides({**row.overrides, "realtime.timing_frames": 1,
                                                       "realtime.warmup_frames": 0})
        return sc, realtime.render(sc)

    # ----------------------------------------------------------------------------- E2
    def e2(self) -> Section:
        from realtime.engine import levels

        spec = "builtin:sphere-phong"
        rows_out, best = [], {}
        for n in EXPONENTS:
            for s in self.s.e2_faces:
                rows = [self.row(spec, {"objects.*.material.exponent": n, "realtime.face_size": s,
                                        "realtime.lod_bias": b}, "E2") for b in self.s.e2_biases]
                mc = self.row(spec, {"objects.*.material.exponent": n, "realtime.face_size": s,
                                     "realtime.lod_mapping": "mcguire", "realtime.lod_bias": 0.0}, "E2")
                top = max(rows, key=lambda r: r.psnr if r.psnr is not None else -1e9)
                best[(n, s)] = (top, mc, rows)
                formula = levels.mcguire_offset(s, n)
                ends = (min(self.s.e2_biases), max(self.s.e2_biases))
                edge = " (edge of the range)" if top.lod_bias in ends else ""
                rows_out.append([f"{n:g}", s, f"{top.lod_bias:g}{edge}", f2(top.psnr), f"{formula:.2f}",
                              f2(mc.psnr), f2(top.noise_floor_psnr)])
        header = ["N", "face size", "best bias (paper mapping)", "PSNR at best", "McGuire offset",
                  "PSNR with McGuire", "noise floor"]
        plt = plots.pyplot()
        fig, axes = plt.subplots(1, len(EXPONENTS), figsize=(4 * len(EXPONENTS), 3.4), squeeze=False)
        for j, n in enumerate(EXPONENTS):
            ax = axes[0, j]
            for s in self.s.e2_faces:
                top, mc, rows = best[(n, s)]
                ax.plot([r.lod_bias for r in rows], [r.psnr for r in rows], "o-", ms=3, label=f"{s}²")
                ax.axvline(levels.mcguire_offset(s, n), color=ax.lines[-1].get_color(), ls=":", lw=0.8)
            ax.set_title(f"N = {n:g}")
            ax.set_xlabel("LOD bias (dotted: McGuire offset)")
            ax.set_ylabel("PSNR (dB)")
            ax.grid(alpha=0.3)
            ax.legend(fontsize=7, title="face")
        plots.save(fig, self.out / "figures/e2_glossy.png")
        md = md_table(header, rows_out)
        return Section("E2 glossy: best LOD bias per exponent and face size",
                       [table(header, rows_out), figure("figures/e2_glossy.png", "E2")], md, ["figures/e2_glossy.png"])

    # ----------------------------------------------------------------------------- E3
    def e3(self) -> Section:
        import groundtruth
        from groundtruth.exact import raycast

        spec = "builtin:sphere-blend"
        plt = plots.pyplot()
        fig, ax = plt.subplots(figsize=(6.4, 4.0))
        rows_out = []
        edges = np.linspace(0.0, 1.0, 11)
        for f0 in F0S:
            # glossy LOD from McGuire's mapping, so that the error left is the blend's, not a bias choice
            r = self.row(spec, {"objects.*.material.f0": f0, "realtime.lod_mapping": "mcguire"}, "E3")
            sc, test = self.image_of(r)
            ref = groundtruth.render(sc)  # cached by the row
            mask = metrics.common_mask(test.mask, ref.mask)
            hits = raycast.cast(sc, 1)
            cos_nv = np.clip((hits.normal * -hits.direction).sum(-1)[..., 0], 0, 1)
            err = np.abs(metrics.display(sc, test.rgb) - metrics.display(sc, ref.rgb)).mean(-1)
            centres, rms = [], []
            for lo, hi in zip(edges[:-1], edges[1:], strict=True):
                sel = mask & (cos_nv >= lo) & (cos_nv < hi)
                if sel.sum() >= 5:
                    centres.append(math.degrees(math.acos((lo + hi) / 2)))
                    rms.append(float(np.sqrt(np.mean(err[sel] ** 2))))
            ax.plot(centres, rms, "o-", label=f"f0 = {f0:g}")
            grazing = rms[0] if centres and centres[0] > 70 else None
            rows_out.append([f"{f0:g}", f2(r.psnr), f"{r.ssim:.4f}", "-" if grazing is None else f"{grazing:.4f}",
                          f"{rms[-1]:.4f}" if rms else "-"])
        ax.set_xlabel("viewing angle from the normal (degrees)")
        ax.set_ylabel("RMS display error")
        ax.set_title("Fresnel blends: error against viewing angle")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
        plots.save(fig, self.out / "figures/e3_fresnel.png")
        header = ["f0", "PSNR", "SSIM", "RMS error at grazing (n.v < 0.1)", "RMS error facing (n.v > 0.9)"]
        note = ("sphere-blend (N = 100, face size 64) with the glossy LOD from McGuire's mapping; RMS of the "
                "display-space error in bands of n.v, plotted against the viewing angle acos(n.v).")
        md = md_table(header, rows_out) + "\n\n" + note
        return Section("E3 Fresnel blends: error against viewing angle", [table(header, rows_out), paragraph(note),
                       figure("figures/e3_fresnel.png", "E3")], md, ["figures/e3_fresnel.png"])

    # ----------------------------------------------------------------------------- E4
    def e4(self) -> Section:
        import realtime
        import scenes
        from realtime.engine.display import display_ms
        from scenes.model.tonemap import adaptation_luminance

        sets = [("diffuse (SH9)", "builtin:sphere-diffuse", False), ("glossy (phong)", "builtin:sphere-phong", False),
                ("diffuse + glossy + Fresnel (blend)", "builtin:sphere-blend", False),
                ("blend + tone mapping", "builtin:sphere-blend", True)]
        rows_out, series = [], {}
        for label, spec, tm in sets:
            for s in self.s.e4_faces:
                sc = scenes.load(spec).with_overrides({**self.base(), "realtime.face_size": s,
                                                       "realtime.rotate_deg_per_frame": 1.0,
                                                       "realtime.timing_frames": max(self.s.frames, 20)})
                r = realtime.render(sc)
                total = r.timings["total"]
                disp = None
                if tm:
                    t = sc.tonemap
                    disp = display_ms(r.rgb, t.key, t.white, t.exposure,
                                      adaptation_luminance(sc.environment.radiance()),
                                      frames=max(self.s.frames, 20))["display"]
                    total += disp
                series.setdefault(label, []).append((s, total))
                rows_out.append([label, s, f2(r.timings["filter"]), f2(r.timings["draw"]), f2(disp), f2(total)])
                self.progress()
        plt = plots.pyplot()
        fig, ax = plt.subplots(figsize=(6.4, 4.0))
        for label, pts in series.items():
            ax.plot([p[0] for p in pts], [p[1] for p in pts], "o-", label=label)
        ax.set_xscale("log", base=2)
        ax.set_yscale("log")
        ax.set_xlabel("face size")
        ax.set_ylabel("frame time (ms, median)")
        ax.set_title("Frame time by effect set (map refiltered every frame)")
        ax.grid(alpha=0.3, which="both")
        ax.legend(fontsize=8)
        plots.save(fig, self.out / "figures/e4_frame_time.png")
        header = ["effects", "face size", "filter ms", "draw ms", "tone map ms", "total ms"]
        from realtime.engine.context import renderer_name

        note = (f"{self.s.size}x{self.s.size} pixels, base {sc.realtime.base_size}, median of "
                f"{max(self.s.frames, 20)} frames after warm-up, the environment turned 1 degree per frame; "
                f"GL: {renderer_name()}.")
        return Section("E4 frame time by effect set and face size", [table(header, rows_out), paragraph(note),
                       figure("figures/e4_frame_time.png", "E4")], md_table(header, rows_out) + "\n\n" + note,
                       ["figures/e4_frame_time.png"])

    # ----------------------------------------------------------------------------- E5
    def e5(self) -> Section:
        import scenes
        from groundtruth.pathtracer.reference import render, second_seed

        spec = "builtin:sphere-blend"
        scene = scenes.load(spec).with_overrides(self.base())
        render(scene, spp=4, use_cache=False)  # compile the kernels outside the timings
        rows_out, pts = [], []
        for spp in self.s.e5_spps:
            a = render(scene, spp=spp, seed=0, use_cache=False)
            b = render(scene, spp=spp, seed=second_seed(0), use_cache=False)
            mask = metrics.common_mask(a.mask, b.mask)
            floor = metrics.noise_floor_psnr(metrics.display(scene, a.rgb), metrics.display(scene, b.rgb), mask)
            secs = float(np.median([a.timings["render"], b.timings["render"]]) / 1e3)
            pts.append((spp, floor, secs))
            rows_out.append([spp, f2(floor), f"{secs:.2f}"])
            self.progress()
        plt = plots.pyplot()
        fig, ax = plt.subplots(figsize=(6.0, 3.8))
        ax.plot([p[0] for p in pts], [p[1] for p in pts], "o-", label="noise floor")
        ax.set_xscale("log", base=2)
        ax.set_xlabel("samples per pixel")
        ax.set_ylabel("noise floor PSNR (dB)")
        ax2 = ax.twinx()
        ax2.plot([p[0] for p in pts], [p[2] for p in pts], "s--", color="tab:red", label="seconds")
        ax2.set_yscale("log")
        ax2.set_ylabel("render seconds", color="tab:red")
        ax.grid(alpha=0.3, which="both")
        plots.save(fig, self.out / "figures/e5_convergence.png")
        from groundtruth.pathtracer.variant import variant_name

        header = ["spp", "noise floor PSNR (dB)", "render s (median of 2)"]
        note = (f"sphere-blend at {self.s.size}x{self.s.size}, Mitsuba {variant_name()}, uncached. Every 4x spp "
                "should add 6.02 dB (Monte Carlo noise falls as 1/sqrt(spp)).")
        return Section("E5 reference convergence", [table(header, rows_out), paragraph(note),
                       figure("figures/e5_convergence.png", "E5")], md_table(header, rows_out) + "\n\n" + note,
                       ["figures/e5_convergence.png"])


def e6_section(spp: int, progress) -> Section:
    from experiments.paper import e06_stability as stability

    rows = stability.run(spp=spp, progress=progress)
    header = ["class", "case", "expected", "what happened"]
    cells = [[r.get("class", ""), r["case"], r["expected"], stability.outcome_text(r)] for r in rows]
    bad = sum(not r["ok"] for r in rows)
    counts = stability.counts(rows)
    note = (f"{len(rows)} hard cases, {bad} unexpected ({counts}). The same cases are asserted in tests/hard/. "
            "Sun cases: a diffuse sphere under the sky seen from below the horizon; min E is SH9 irradiance over "
            "the sphere.")
    md = md_table(header, cells) + "\n\n" + note
    return Section("E6 stability: hard cases", [table(header, cells), paragraph(note)], md)


def count_steps(s: Settings, quick: bool) -> int:
    from experiments.paper import e06_stability as stability
    from experiments.paper import e07_accuracy_time_ladder as ladder
    from experiments.paper import e08_occlusion as e8
    from experiments.paper import e09_parameterizations as e9
    from experiments.paper import e10_voxel_cone_tracing as e10

    return (2 * len(s.e1_faces) + len(EXPONENTS) * len(s.e2_faces) * (len(s.e2_biases) + 1) + len(F0S)
            + 4 * len(s.e4_faces) + len(s.e5_spps) + stability.count_parts()
            + ladder.count_steps(ladder.QUICK if quick else ladder.FULL) + e9.count_steps(quick)
            + e8.count_steps(quick) + e10.count_steps(quick))


def reference_plan(s: Settings) -> list[tuple[str, dict]]:
    """(spec, overrides) with the distinct references of E1-E3 (a face size or LOD bias does not change
    a reference): submitted up front on a Dask cluster (Suite.prefetch)."""
    return ([("builtin:sphere-diffuse", {})]
            + [("builtin:sphere-phong", {"objects.*.material.exponent": n}) for n in EXPONENTS]
            + [("builtin:sphere-blend", {"objects.*.material.f0": f0, "realtime.lod_mapping": "mcguire"})
               for f0 in F0S])


def run(out: Path, quick: bool = False, workers: int | None = None, scheduler: str | None = None,
        cluster=None) -> Path:
    """Run the suite into `out` (checked and locked first: one writer per folder); returns the path of
    index.html. `workers` / `scheduler` / `cluster`: references as Dask tasks (experiments/runs/dask_cluster.py)."""
    from experiments.publish import outputs

    settings = QUICK if quick else FULL
    with outputs.Outputs() as plan, folder_lock(plan.folder(out, "--out")):
        plan.folder(out / "figures", "--out")
        if cluster is None and workers is None and scheduler is None:
            return _run(out, settings, quick)
        from experiments.publish.text import one_line
        from experiments.runs import dask_cluster as distributed

        with distributed.maybe_cluster(workers, scheduler, cluster) as cl:
            index = _run(out, settings, quick, cl)
            print(one_line(cl.summary()))
            return index


def _run(out: Path, settings: Settings, quick: bool, cluster=None) -> Path:
    from rich import progress as rp

    from experiments.publish import outputs, report

    t0 = time.perf_counter()
    timings = {}
    columns = [rp.TextColumn("[bold]paper"), rp.BarColumn(), rp.MofNCompleteColumn(), rp.TimeElapsedColumn(),
               rp.TextColumn("eta"), rp.TimeRemainingColumn(), rp.TextColumn("{task.description}")]
    with outputs.rich_progress(*columns) as progress:
        task = progress.add_task("", total=count_steps(settings, quick))
        suite = Suite(out, settings, lambda: progress.advance(task), cluster)
        if cluster is not None:
            progress.update(task, description="references on Dask")
            suite.prefetch(reference_plan(settings), quadratures=("builtin:sphere-diffuse",))
        sections = []
        for name in ("e1", "e2", "e3", "e4", "e5"):
            progress.update(task, description=name.upper())
            t = time.perf_counter()
            sections.append(getattr(suite, name)())
            timings[name.upper()] = time.perf_counter() - t
        from experiments.paper import e07_accuracy_time_ladder as ladder
        from experiments.paper import e08_occlusion as occlusion
        from experiments.paper import e09_parameterizations as e9
        from experiments.paper import e10_voxel_cone_tracing as vct_experiment

        # the experiments in their own modules: run(suite, quick, progress) -> Section
        for name, module in (("E7", ladder), ("E9", e9), ("E8", occlusion), ("E10", vct_experiment)):
            progress.update(task, description=name)
            t = time.perf_counter()
            sections.append(module.run(suite, quick, lambda: progress.advance(task)))
            timings[name] = time.perf_counter() - t
        progress.update(task, description="E6")
        t = time.perf_counter()
        sections.append(e6_section(64 if quick else 256, lambda: progress.advance(task)))
        timings["E6"] = time.perf_counter() - t
    suite.keep_only_used()
    total = time.perf_counter() - t0
    subtitle = (f"{'quick' if quick else 'full'} suite, {settings.size}x{settings.size} pixels, references at "
                f"{settings.spp} spp; this run took {total / 60:.1f} min (" +
                ", ".join(f"{k} {v:.0f} s" for k, v in timings.items()) + f"), reusing {suite.reused} of "
                f"{len(suite.used)} compared configurations already in {RESULTS}")
    outputs.write_text(out / report.SECTIONS, json.dumps({
        "title": TITLE, "subtitle": subtitle, "quick": quick, "seconds": timings, "total_s": total,
        "sections": [vars(s) for s in sections]}, indent=1))
    return report.build(out, title=TITLE, sections=sections, subtitle=subtitle)
