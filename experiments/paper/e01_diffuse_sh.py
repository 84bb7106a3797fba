"""E1 of the paper suite: diffuse lighting from SH9 irradiance, by cube face size.

sphere-diffuse with SH9 built from faces 8 ... 256, compared with the path-traced reference and with
brute-force irradiance convolution (the quadrature of groundtruth/exact/quadrature.py), and SH9's own
irradiance error against the exact irradiance at 4000 random normals; filter and draw times.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

import scenes
from experiments.measure import metrics
from experiments.paper.context import Context
from experiments.publish import plots
from experiments.publish.report import Section, f2, figure, md_table, paragraph, table
from groundtruth.exact import quadrature
from realtime.engine import sh

NUMBER = 1
TITLE = "E1 diffuse: SH9 irradiance by face size"
SPEC = "builtin:sphere-diffuse"
FIGURE = "figures/e1_diffuse.png"


@dataclass(frozen=True)
class Settings:
    faces: tuple[int, ...]  # cube face sizes the SH9 coefficients are projected from


QUICK = Settings(faces=(8, 16, 32, 64, 128))
FULL = Settings(faces=(8, 16, 32, 64, 128, 256))


def count_steps(settings: Settings) -> int:
    """Progress steps of `run`: one per row."""
    return len(settings.faces)


def run(context: Context, settings: Settings) -> Section:
    """E1's rows through `context.row` (resumable) and its section."""
    context.prefetch([(SPEC, {})], quadratures=(SPEC,))
    scene = scenes.load(SPEC).with_overrides(context.base())
    brute, brute_s = context.quadrature(scene)
    env = scene.environment.radiance()
    rng = np.random.default_rng(0)
    normals = rng.normal(size=(4000, 3))
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    t0 = time.perf_counter()
    exact = math.pi * quadrature.irradiance(quadrature.cell_grid(env, quadrature.DIFFUSE_WIDTH), normals)
    conv_ms = (time.perf_counter() - t0) * 1e3 / len(normals)
    rows, rows_out = [], []
    for s in settings.faces:
        r = context.row(SPEC, {"realtime.face_size": s}, "E1")
        _, test = context.image_of(r)
        e_sh = sh.irradiance_from_sh(np.asarray(test.meta["sh_coeffs"]), normals)
        sh_err = float(np.sqrt(np.mean((e_sh - exact) ** 2)) / np.sqrt(np.mean(exact**2)))
        mask = metrics.common_mask(test.mask, brute.mask)
        vs_brute = metrics.psnr(metrics.display(scene, test.rgb), metrics.display(scene, brute.rgb), mask)
        rows.append((r, sh_err, vs_brute))
        rows_out.append([s, f2(r.psnr), f2(r.noise_floor_psnr), f2(vs_brute), f"{100 * sh_err:.3f}%",
                         f2(r.realtime_ms["filter"]), f2(r.realtime_ms["draw"])])
    header = ["face size", "PSNR vs reference", "noise floor", "PSNR vs brute force", "SH9 irradiance rel. RMS",
              "filter ms", "draw ms"]
    plot(rows, context.out / FIGURE)
    note = (f"Brute-force irradiance convolution (quadrature over a {quadrature.DIFFUSE_WIDTH}-wide cell grid, "
            f"numpy on the CPU): {brute_s:.1f} s for the whole {context.common.size}x{context.common.size} image, "
            f"{conv_ms:.3f} ms per normal; SH9 replaces it by a 4x4 matrix per channel.")
    md = md_table(header, rows_out) + "\n\n" + note
    return Section(TITLE, [table(header, rows_out), paragraph(note), figure(FIGURE, "E1")], md, [FIGURE])


def plot(rows: list, path) -> None:
    """PSNR against face size (vs reference, vs brute force, the noise floor) and SH9's irradiance error."""
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
    plots.save(fig, path)
