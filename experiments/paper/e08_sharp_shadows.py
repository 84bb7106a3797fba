"""E8's sharp-shadow part: all-frequency shadows against SH's low-frequency ones.

On sphere-on-plane (a contact shadow on a plane) and teapot-blend (self-shadowing in its spout, handle and lid)
under three probes: the broadest and the most concentrated packaged probe (e08_sharp_probes: the solid angle that
holds half the energy) and the sun sky (`builtin:sky` at its defaults: sun 1e3 x the zenith radiance, 45 degrees
high, azimuth 30 degrees, radius 2 degrees), against the same path-traced references, `psnr_unbiased` against the
frame's milliseconds, the precomputation's seconds and the transfer's bytes per vertex of:

- the paper (no occlusion), for scale;
- SH PRT (realtime/techniques/prt) of orders 2..8, shadowed, with interreflection (Sloan et al. 2002);
- wavelet PRT (realtime/techniques/wavelet_prt; Ng, Ramamoorthi & Hanrahan 2003), shadowed, cube sizes 16..64,
  K = 16..1024 kept lighting terms;
- the light array with shadow maps (realtime/techniques/lights, shadow_maps);
- the path tracer's spp ladder on the same axes.

The readings (saturation K, the 6 dB / 2x criterion) are e08_sharp_analysis; the figures e08_sharp_figures.
"""

from __future__ import annotations

from collections import defaultdict
from dataclasses import dataclass, replace

import numpy as np

import scenes
from experiments.measure import convergence, metrics
from experiments.measure.results import ResultRow
from experiments.paper import e08_sharp_analysis as analysis
from experiments.paper import e08_sharp_figures as figures
from experiments.paper import e08_sharp_probes as probes_mod
from experiments.paper.context import Context
from experiments.paper.e08_overrides import fits, lights_ov, prt_ov, wavelet_ov
from experiments.publish import images, report
from experiments.publish.plots import frame_ms
from experiments.publish.report import f2, unbiased_cell
from realtime.techniques.prt.prt import transfer_objects
from realtime.techniques.prt.prt_transfer import cached_transfer
from realtime.techniques.prt.settings import effective_settings
from realtime.techniques.wavelet_prt import wavelet_transfer
from scenes import SceneError
from scenes.environment import environments

SCENES = (("sphere-on-plane", "builtin:sphere-on-plane"), ("teapot-blend", "builtin:teapot-blend"))
SKY = "builtin:sky"
#: the case of the 6 dB / 2x criterion: (scene, probe spec)
PRIMARY = ("sphere-on-plane", SKY)


@dataclass(frozen=True)
class SharpSettings:
    scenes: tuple[tuple[str, str], ...]  # (name, spec)
    candidates: tuple[str, ...]  # packaged probes ranked by concentration (the broadest and the sharpest are used)
    sh_orders: tuple[int, ...]
    sh_rays: int  # PRT's visibility rays
    sh_bounces: int
    wavelet_cubes: tuple[int, ...]  # cube sizes on the primary case
    wavelet_cubes_other: tuple[int, ...]  # cube sizes on every other scene and probe
    wavelet_terms: tuple[int, ...]  # K
    wavelet_bounces: int
    wavelet_unbounced: tuple[int, ...]  # cube sizes run without bounces (their bounce gather exceeds the memory guard)
    light_arrays: tuple[tuple[str, int, int], ...]  # (placement, count, shadow map size)
    frames: int  # timed frames per row (medians)
    max_spp: int  # the path tracer's ladder


QUICK = SharpSettings(scenes=SCENES, candidates=environments.PROBES, sh_orders=(2, 4, 8), sh_rays=256, sh_bounces=1,
                      wavelet_cubes=(16,), wavelet_cubes_other=(16,), wavelet_terms=(16, 256), wavelet_bounces=1,
                      wavelet_unbounced=(), light_arrays=(("geodesic", 42, 256),), frames=3, max_spp=256)
# two bounces for both: E8's own rows show them worth 5 dB over one on sphere-on-plane (SH order 4 under uffizi)
FULL = SharpSettings(scenes=SCENES, candidates=environments.PROBES, sh_orders=(2, 3, 4, 5, 6, 7, 8), sh_rays=1024,
                     sh_bounces=2, wavelet_cubes=(16, 32, 64), wavelet_cubes_other=(32,),
                     wavelet_terms=(16, 64, 256, 1024), wavelet_bounces=2, wavelet_unbounced=(64,),
                     light_arrays=(("geodesic", 42, 1024), ("median_cut", 64, 1024)), frames=5, max_spp=1024)


def probes(s: SharpSettings) -> list[tuple[str, str, float | None]]:
    """(name, spec, Omega_1/2 in sr) of the probes used: the broadest and the most concentrated candidate, then the
    sun sky."""
    envs = {name: environments.builtin(name) for name in s.candidates}
    broad, sharp = probes_mod.pick(envs)
    omega = dict(probes_mod.rank(envs))
    out = [(f"{broad} (broad)", f"builtin:{broad}", omega[broad])]
    if sharp != broad:
        out.append((f"{sharp} (small bright sources)", f"builtin:{sharp}", omega[sharp]))
    return out + [("sun sky", SKY, probes_mod.concentration(environments.builtin("sky")))]


def wavelet_cubes(s: SharpSettings, scene_name: str, probe_spec: str) -> tuple[int, ...]:
    return s.wavelet_cubes if (scene_name, probe_spec) == PRIMARY else s.wavelet_cubes_other


def configs(scene, s: SharpSettings, cubes: tuple[int, ...]) -> list[dict]:
    """The rows of one scene and probe (without the probe's override): paper, SH orders, wavelet cube x K, arrays."""
    out: list[dict] = [{}]
    out += [prt_ov(o, s.sh_rays, s.sh_bounces) for o in s.sh_orders]
    out += [wavelet_ov(c, k, 0 if c in s.wavelet_unbounced else s.wavelet_bounces)
            for c in cubes for k in s.wavelet_terms if k <= 6 * c * c]
    out += [lights_ov(scene, placement, n, size) for placement, n, size in s.light_arrays if fits(n, size)]
    return out


def count_steps(s: SharpSettings) -> int:
    """Progress steps of `run`: per scene and probe its spp ladder and one per row."""
    n = 0
    for name, spec in s.scenes:
        scene = scenes.load(spec)
        for _, probe_spec, _ in probes(s):
            n += 1 + len(configs(scene, s, wavelet_cubes(s, name, probe_spec)))
    return n


@dataclass
class Case:
    """One scene under one probe: its rows, the configurations refused (and why), its spp ladder."""
    scene: str
    probe: str
    spec: str
    probe_spec: str
    rows: list[ResultRow]
    refused: list[tuple[str, str]]
    curve: list


def run_cases(context: Context, s: SharpSettings) -> list[Case]:
    timing = {"realtime.timing_frames": s.frames, "realtime.warmup_frames": 1}
    out = []
    for name, spec in s.scenes:
        for probe, probe_spec, _ in probes(s):
            env = {"environment.map": probe_spec}
            scene = scenes.load(spec).with_overrides({**context.base(), **env})
            curve = convergence.curve(scene, max_spp=s.max_spp)
            context.progress()
            case = Case(name, probe, spec, probe_spec, [], [], curve)
            for c in configs(scene, s, wavelet_cubes(s, name, probe_spec)):
                try:
                    row = context.row(spec, {**timing, **env, **c}, "E8", curve=curve)
                except (SceneError, MemoryError) as exc:  # a technique refuses the configuration (a size, its memory)
                    context.progress()
                    case.refused.append((", ".join(f"{k.split('.', 1)[1]} = {v}" for k, v in c.items()), str(exc)))
                    continue
                case.rows.append(with_costs(context, row))
            out.append(case)
    return out


def with_costs(context: Context, row: ResultRow) -> ResultRow:
    """The row with `precompute_s` and `bytes_per_vertex` of its transfer in `extra` (PRT's from its cache entry, the
    bytes of the arrays the shader reads over the vertices; wavelet PRT's from the render's meta)."""
    t = row.techniques
    if "bytes_per_vertex" in row.extra or t.get("diffuse") not in ("prt", "wavelet_prt"):
        return row
    if t["diffuse"] == "prt":
        scene = context.scene_of(row)
        st = effective_settings(scene)
        arrays, info = cached_transfer(transfer_objects(scene), st.order, st.rays, st.bounces, st.shadowed)
        seconds = info.get("compute_seconds", info.get("seconds"))
        per_vertex = sum(a.nbytes for a in arrays) / max(int(info["vertices"]), 1)
    else:
        kept = images.load_measured(context.out, row)
        meta = {} if kept is None else kept.test.meta.get("wavelet_prt", {})
        seconds, per_vertex = meta.get("compute_seconds", meta.get("seconds")), meta.get("bytes_per_vertex")
    row = replace(row, extra={**row.extra, "precompute_s": seconds, "bytes_per_vertex": per_vertex})
    context.replace_row(row)
    return row


def precompute_s(r: ResultRow) -> float | None:
    """PRT's and wavelet PRT's transfer seconds (their compute time, also when read from the cache); otherwise the
    techniques' own one-off set-up."""
    if r.extra.get("precompute_s") is not None:
        return r.extra["precompute_s"]
    ms = r.realtime_ms.get("precompute")
    return None if ms is None else ms / 1e3


def family(r: ResultRow) -> str:
    return analysis.family(r.techniques)


def label(r: ResultRow) -> str:
    return analysis.label(r.techniques)


def point(r: ResultRow) -> analysis.Point:
    return analysis.Point(label(r), r.psnr_unbiased, frame_ms(r))


def saturations(case: Case) -> list[list[str]]:
    """Per cube size: K at saturation, the best K and its dB, the dB of every K."""
    by_cube: dict[int, list[tuple[int, float | None]]] = defaultdict(list)
    for r in case.rows:
        if r.techniques.get("diffuse") == "wavelet_prt":
            w = r.techniques["wavelet_prt"]
            by_cube[int(w["cube_size"])].append((int(w["terms"]), r.psnr_unbiased))
    out = []
    for cube in sorted(by_cube):
        pts = sorted(by_cube[cube])
        known = [(k, db) for k, db in pts if db is not None]
        best = max(known, key=lambda x: x[1]) if known else (None, None)
        out.append([case.scene, case.probe, str(cube), str(analysis.saturation(pts)), str(best[0]), f2(best[1]),
                    ", ".join(f"{k}: {f2(db)}" for k, db in pts)])
    return out


def verdict(case: Case) -> analysis.Verdict:
    sh = [point(r) for r in case.rows if family(r) == analysis.SH]
    wav = [point(r) for r in case.rows if family(r).startswith(analysis.WAVELET)]
    return analysis.criterion(sh, wav)


def heat_lines(context: Context, cases: list[Case], fraction: int = 3):
    """Per case: the reference's crop and the error crops of the best SH, best wavelet and shadow-map rows, cropped
    where the paper (no occlusion) errs most (e08_sharp_figures.crop_window)."""
    columns = ((analysis.SH, "best SH PRT"), (analysis.WAVELET, "best wavelet PRT"), (analysis.LIGHTS, "shadow maps"))
    lines = []
    for case in cases:
        paper = next((r for r in case.rows if family(r) == analysis.PAPER), None)
        if paper is None:
            continue
        scene, mask, err = context.error_of(paper)
        size = max(8, min(err.shape) // fraction)
        corner = figures.crop_window(np.where(mask, err, 0.0), size)
        kept = images.load_reference(context.out, paper)
        ref = None if kept is None else figures.crop(metrics.display(scene, kept.reference.astype(np.float32)),
                                                    corner, size)
        cells = []
        for prefix, title in columns:
            b = report.best_row(case.rows, lambda r, p=prefix: family(r).startswith(p))
            if b is None:
                cells.append((title, None))
                continue
            _, m, e = context.error_of(b)
            cells.append((f"{label(b)}\n{b.psnr_unbiased:.1f} dB", figures.crop(np.where(m, e, 0.0), corner, size)))
        lines.append((f"{case.scene}, {case.probe}", ref, cells))
    return lines


def unbounced_why(s: SharpSettings) -> list[str]:
    """Why the cube sizes of `wavelet_unbounced` run without bounces: the bytes wavelet PRT's memory guard counts for
    their bounce gather on the primary scene, against what it allows."""
    if not s.wavelet_unbounced:
        return []
    spec = dict(s.scenes).get(PRIMARY[0])
    if spec is None:
        return []
    vertices = sum(len(o.mesh.positions) for o in scenes.load(spec).objects)
    limit = wavelet_transfer.memory_limit()
    return [f"{PRIMARY[0]} ({vertices} vertices): wavelet PRT at cube size {c} with {s.wavelet_bounces} bounces needs "
            f"{wavelet_transfer.transfer_bytes(vertices, c, s.wavelet_bounces) / 2**30:.1f} GiB by its memory guard's "
            f"count, above the {limit / 2**30:.1f} GiB it allows here (half the physical memory): its rows run "
            f"without bounces ({wavelet_transfer.transfer_bytes(vertices, c, 0) / 2**30:.1f} GiB), so they lack the "
            "interreflection the reference has and the other rows simulate." for c in s.wavelet_unbounced]


def findings(cases: list[Case], s: SharpSettings) -> list[str]:
    out = []
    for case in (c for c in cases if (c.scene, c.probe_spec) == PRIMARY):
        v = verdict(case)
        out.append(f"Criterion ({case.scene} under the {case.probe}: wavelet PRT at some K at least "
                   f"{analysis.MARGIN_DB:g} dB above the best SH order, at most {analysis.TIME_FACTOR:g}x its frame "
                   f"time): {'HOLDS' if v.holds else 'DOES NOT HOLD'}: {v.why}.")
    out += unbounced_why(s)
    for case in cases:
        parts = []
        for fam in (analysis.PAPER, analysis.SH, analysis.WAVELET, analysis.LIGHTS):
            b = report.best_row(case.rows, lambda r, f=fam: family(r).startswith(f))
            if b is not None:
                parts.append(f"{label(b)} {b.psnr_unbiased:.2f} dB in {f2(frame_ms(b))} ms")
        v = verdict(case)
        primary = " (the criterion's case)" if (case.scene, case.probe_spec) == PRIMARY else ""
        sat = "; ".join(f"cube {line[2]}: K = {line[3]}" for line in saturations(case))
        out.append(f"{case.scene} under {case.probe}{primary}: " + "; ".join(parts) + ". "
                   + (f"Wavelet PRT saturates (within {analysis.SATURATION_DB:g} dB of its best K) at {sat}. " if sat
                      else "") + "6 dB / 2x criterion: " + ("holds" if v.holds else "does not hold") + f": {v.why}.")
        for c, why in case.refused:
            out.append(f"{case.scene} under {case.probe}: refused {c}: {why}")
    return out


def section(context: Context, s: SharpSettings) -> tuple[list[dict], str, list[str]]:
    """The sharp-shadow part's rows (through `context.row`) and its blocks, Markdown and figures."""
    cases = run_cases(context, s)
    figure, heat = "figures/e8_sharp.png", "figures/e8_sharp_heat.png"
    figures.plot([(f"{c.scene}, {c.probe}", c.rows, c.curve) for c in cases], family, context.out / figure)
    figures.plot_heat(heat_lines(context, cases), context.out / heat)
    probe_header = ["probe", "solid angle of a quarter of the energy (sr)", "solid angle of half the energy (sr)"]
    probe_rows = [[name, f"{probes_mod.concentration(environments.builtin(spec.split(':', 1)[1]), 0.25):.4f}",
                   f"{omega:.4f}"] for name, spec, omega in probes(s)]
    header = ["scene", "probe", "technique", "unbiased PSNR dB", "frame ms", "of which filter ms", "precompute s",
              "bytes per vertex"]
    table = []
    for case in cases:
        for r in sorted(case.rows, key=lambda r: (family(r), frame_ms(r) or 0.0)):
            bpv = r.extra.get("bytes_per_vertex")
            table.append([case.scene, case.probe, label(r), unbiased_cell(r), f2(frame_ms(r)),
                          f2(r.realtime_ms.get("filter")), f2(precompute_s(r)), "-" if bpv is None else f"{bpv:.0f}"])
    sat_header = ["scene", "probe", "cube size", f"K at saturation (within {analysis.SATURATION_DB:g} dB of the best)",
                  "best K", "best dB", "dB per K"]
    sat = [line for case in cases for line in saturations(case)]
    found = findings(cases, s)
    note = (f"Probes ranked by the solid angle holding half their energy (smallest: most concentrated). SH PRT: "
            f"{s.sh_rays} visibility rays, {s.sh_bounces} bounce(s); wavelet PRT: {s.wavelet_bounces} bounce(s), "
            f"cube sizes {', '.join(map(str, s.wavelet_cubes))} on {PRIMARY[0]} under the sun sky, "
            f"{', '.join(map(str, s.wavelet_cubes_other))} elsewhere"
            + (f", cube size(s) {', '.join(map(str, s.wavelet_unbounced))} without bounces (the bounce gather's "
               "memory exceeds wavelet PRT's guard, half the physical memory)" if s.wavelet_unbounced else "")
            + ". Bytes per vertex: the per-vertex transfer the "
            "shader reads (SH: (order + 1)^2 x 3 float32; wavelet: the stored (index, value) pairs). Filter ms: the "
            "per-frame lighting work (SH: the projection; wavelet: the Haar transform, the top-K selection and the "
            "per-vertex sums; the light array: its powers are `lights`, its maps `shadow`). The criterion: "
            f"the best wavelet row at most {analysis.TIME_FACTOR:g}x the frame ms of the best SH order must be "
            f"{analysis.MARGIN_DB:g} dB above it. Heat maps: |real time - reference| of the display values, cropped "
            "where the paper (no occlusion) errs most. Frame ms: medians of the timed frames on llvmpipe, on two cores "
            "shared with other work: differences of 10-20 ms between neighbouring rows are within their noise. "
            "Both PRT families transfer the diffuse lobe only; a blend's glossy lobe is the paper's, unshadowed, in "
            "every PRT row.")
    md = ("### Sharp shadows\n\n" + "\n".join(f"- {f}" for f in found) + "\n\n" + report.md_table(probe_header,
          probe_rows) + "\n\n" + report.md_table(header, table) + "\n\n" + report.md_table(sat_header, sat) + "\n\n"
          + note)
    blocks = [report.paragraph("Sharp shadows"), report.bullets(found), report.table(probe_header, probe_rows),
              report.table(header, table), report.table(sat_header, sat), report.figure(figure, "E8 sharp shadows"),
              report.figure(heat, "E8 sharp shadows heat maps"), report.paragraph(note)]
    return blocks, md, [figure, heat]
