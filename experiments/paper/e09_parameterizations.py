"""E9 of the paper suite: environment parameterizations at equal texel budgets.

The paper stores the environment as a cube map; a dual paraboloid (Heidrich & Seidel 1998, two maps,
view independent) or a sphere map (OpenGL's GL_SPHERE_MAP, one map made for a capture view) is what a
mobile target or an engine with only 2D textures would use. For a mirror-like sphere (Phong N = 1e4),
sphere-phong (N = 100) and sphere-diffuse, at budgets matching cube faces 16 ... 256 (`realtime.base_size
= face_size = s`: the whole chain holds that budget; the maps round s sqrt 3 and s sqrt 6 to powers of
two, 2 s, and the real texel counts are reported), every parameterization is compared with the Mitsuba
reference: PSNR and `psnr_unbiased`, frame ms. The glossy LOD uses McGuire's mapping, carried to the
maps in solid angle (realtime/engine/environment_maps.py), so no bias choice favours one of them.

Beside that: the sampling rates (largest / smallest texel solid angle of the texels wholly inside the
map, and the largest stretch, i.e. the anisotropy of a texel on the sphere) from scenes/; heat maps of
where each parameterization's error goes on the mirror sphere, with the error against the angle between
the reflection and the view (the paraboloids' seam sits at 90 degrees, the sphere map's rim at 180);
the sphere map's error against the angle between its capture view and the render view; per-vertex
against per-pixel reflection vectors on a coarse sphere and on the teapot.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from experiments.measure.results import ResultRow
from experiments.paper.context import Context
from experiments.publish import plots
from experiments.publish.report import Section, bullets, f2, figure, md_table, paragraph, table, unbiased_cell
from groundtruth.exact import raycast
from scenes.environment import cubemap, discmap, paraboloid, spheremap
from scenes.environment.directions import normalize, rotation_y

NUMBER = 9
TITLE = "E9 environment parameterizations at equal texel budgets"

PARAMS = ("cube", "dual_paraboloid", "sphere_map")
LABELS = {"cube": "cube", "dual_paraboloid": "dual paraboloid", "sphere_map": "sphere map"}


@dataclass(frozen=True)
class Settings:
    budgets: tuple[int, ...]  # cube face sizes s (6 s^2 texels)
    angles: tuple[float, ...]  # sphere map: capture view turned from the render view about +Y (degrees)
    angle_budget: int
    heat_budget: int
    vertex_params: tuple[str, ...]  # parameterizations of the per-vertex rows
    vertex_budget: int
    coarse_resolution: int  # latitude bands of the coarse builtin sphere


QUICK = Settings(budgets=(16, 64, 256), angles=(0.0, 45.0, 90.0, 135.0, 180.0), angle_budget=64,
                   heat_budget=16, vertex_params=("cube",), vertex_budget=64, coarse_resolution=12)
FULL = Settings(budgets=(16, 32, 64, 128, 256), angles=tuple(float(a) for a in np.arange(0.0, 180.1, 22.5)),
                  angle_budget=64, heat_budget=16, vertex_params=PARAMS, vertex_budget=64, coarse_resolution=12)

MIRROR = ("mirror sphere (N = 1e4)", "builtin:sphere-phong", {"objects.*.material.exponent": 1e4})
GLOSSY = ("sphere-phong (N = 100)", "builtin:sphere-phong", {"objects.*.material.exponent": 100.0})
DIFFUSE = ("sphere-diffuse", "builtin:sphere-diffuse", {})
SCENES = (MIRROR, GLOSSY, DIFFUSE)


def budget_ov(param: str, face: int, glossy: bool) -> dict:
    ov = {"realtime.parameterization": param, "realtime.base_size": face, "realtime.face_size": face}
    if glossy:
        ov["realtime.lod_mapping"] = "mcguire"
    return ov


def capture_direction(angle_deg: float) -> list[float]:
    """The builtin spheres' view direction (0, 0, -1) turned by `angle_deg` about +Y."""
    d = rotation_y(angle_deg) @ np.array([0.0, 0.0, -1.0])
    return [round(float(x), 12) + 0.0 for x in d]


def vertex_scenes(s: Settings) -> list[tuple[str, str, dict]]:
    coarse = {"objects.*.resolution": s.coarse_resolution}
    return [(f"coarse sphere ({s.coarse_resolution} bands), N = 1e4", "builtin:sphere-phong",
             {"objects.*.material.exponent": 1e4, **coarse}),
            (f"coarse sphere ({s.coarse_resolution} bands), N = 100", "builtin:sphere-phong",
             {"objects.*.material.exponent": 100.0, **coarse}),
            ("mirror teapot (phong N = 1e4)", "builtin:teapot-blend",
             {"objects.*.material": {"type": "phong", "ks": [1.0, 1.0, 1.0], "exponent": 1e4}}),
            ("teapot-blend", "builtin:teapot-blend", {})]


def count_steps(settings: Settings) -> int:
    """Progress steps of `run`: one per row, one for the heat maps."""
    s = settings
    rows = (len(SCENES) * len(s.budgets) * len(PARAMS) + 2 * len(s.angles)
            + len(vertex_scenes(s)) * len(s.vertex_params) * 2)
    return rows + 1  # + the heat maps


# ----------------------------------------------------------------------------- sampling rates


def sampling_rates(face: int) -> list[dict]:
    """Per parameterization at the budget of cube faces `face`: texels, max / min texel solid angle
    (texels wholly inside the map) with its analytic limit, and the largest stretch (ratio of the
    singular values of d direction / d position) over those texels' centres."""
    out = []
    w = cubemap.texel_solid_angles(face)
    c = cubemap.face_coords(face)
    x, y = np.meshgrid(c, c, indexing="xy")
    big, small = discmap.jacobian_singular_values(lambda a, b: normalize(cubemap.face_direction(4, a, b)), x, y)
    out.append({"param": "cube", "size": face, "texels": 6 * face * face, "ratio": float(w.max() / w.min()),
                "limit": 3 * math.sqrt(3), "stretch": float((big / small).max())})
    for mod, limit in ((paraboloid, 4.0), (spheremap, 1.0)):
        m = mod.map_size(face)
        full = discmap.full_texels(m)
        w = mod.texel_solid_angles(m)[0][full]
        x, y = discmap.texel_positions(m)
        big, small = discmap.jacobian_singular_values(mod.position_to_direction, x[full], y[full], h=1e-7)
        out.append({"param": mod.NAME, "size": m, "texels": mod.texel_count(m), "ratio": float(w.max() / w.min()),
                    "limit": limit, "stretch": float((big / small).max())})
    return out


# ----------------------------------------------------------------------------- the experiment


def run(context: Context, settings: Settings) -> Section:
    """E9's rows through `context.row` (resumable) and its section."""
    s = settings
    glossy = {MIRROR[0]: True, GLOSSY[0]: True, DIFFUSE[0]: False}
    budget_rows: dict[tuple[str, int, str], ResultRow] = {}
    for label, spec, ov in SCENES:
        for face in s.budgets:
            for p in PARAMS:
                budget_rows[(label, face, p)] = context.row(spec, {**ov, **budget_ov(p, face, glossy[label])}, "E9")
    angle_rows: dict[tuple[str, float], ResultRow] = {}
    for label, spec, ov in (MIRROR, GLOSSY):
        for a in s.angles:
            angle_rows[(label, a)] = context.row(spec, {**ov, **budget_ov("sphere_map", s.angle_budget, True),
                                                      "realtime.sphere_map.capture": capture_direction(a)}, "E9")
    vertex_rows: dict[tuple[str, str, str], ResultRow] = {}
    for label, spec, ov in vertex_scenes(s):
        for p in s.vertex_params:
            for refl in ("per_pixel", "per_vertex"):
                vertex_rows[(label, p, refl)] = context.row(spec, {**ov, **budget_ov(p, s.vertex_budget, True),
                                                                 "realtime.reflection": refl}, "E9")
    rates = {face: sampling_rates(face) for face in s.budgets}
    heat = heat_maps(context, s, budget_rows, angle_rows)
    context.progress()

    figs = {"psnr": "figures/e9_budgets.png", "rates": "figures/e9_sampling.png", "heat": "figures/e9_heat.png",
            "angle": "figures/e9_capture_angle.png"}
    plot_budgets(budget_rows, s, context.out / figs["psnr"])
    plot_rates(rates, context.out / figs["rates"])
    plot_heat(heat, s, context.out / figs["heat"])
    plot_angles(angle_rows, budget_rows, s, context.out / figs["angle"])

    t1_head = ["scene", "budget (cube face)", "parameterization", "map side", "texels", "PSNR dB",
               "unbiased PSNR dB", "filter ms", "draw ms", "frame ms"]
    t1 = []
    for (label, face, p), r in budget_rows.items():
        side, texels = store_size(p, face)
        t1.append([label, face, LABELS[p], side, texels, f2(r.psnr), unbiased_cell(r), f2(r.realtime_ms.get("filter")),
                   f2(r.realtime_ms.get("draw")), f2(r.realtime_ms.get("total"))])
    t2_head = ["budget (cube face)", "parameterization", "side", "texels", "max/min texel solid angle",
               "analytic limit", "largest stretch"]
    t2 = [[face, LABELS[x["param"]], x["size"], x["texels"], f"{x['ratio']:.3f}", f"{x['limit']:.3f}",
           f"{x['stretch']:.3g}"] for face, xs in rates.items() for x in xs]
    t3_head = ["scene", "capture vs render view (deg)", "sphere map PSNR dB", "unbiased PSNR dB",
               f"cube PSNR at face {s.angle_budget}", "frame ms"]
    t3 = []
    for (label, a), r in angle_rows.items():
        cube = budget_rows.get((label, s.angle_budget, "cube"))
        t3.append([label, f"{a:g}", f2(r.psnr), unbiased_cell(r), f2(cube.psnr) if cube else "-",
                   f2(r.realtime_ms.get("total"))])
    t4_head = ["scene", "parameterization", "per-pixel PSNR dB", "per-vertex PSNR dB", "per-vertex - per-pixel dB",
               "per-pixel frame ms", "per-vertex frame ms", "unsimulated effects"]
    t4 = []
    for label, _, _ in vertex_scenes(s):
        for p in s.vertex_params:
            a, b = vertex_rows[(label, p, "per_pixel")], vertex_rows[(label, p, "per_vertex")]
            diff = None if a.psnr is None or b.psnr is None else b.psnr - a.psnr
            t4.append([label, LABELS[p], f2(a.psnr), f2(b.psnr), "-" if diff is None else f"{diff:+.2f}",
                       f2(a.realtime_ms.get("total")), f2(b.realtime_ms.get("total")),
                       ", ".join(a.unsimulated_effects) or "-"])

    findings = summarize(budget_rows, angle_rows, vertex_rows, rates, heat, s)
    note = ("Budgets: `realtime.base_size = face_size = s`, so the whole mip chain holds the budget; a cube of "
            "face s has 6 s^2 texels, the dual paraboloid two maps of side 2 s (s sqrt 3 rounded to a power of "
            "two: 8 s^2 texels) and the sphere map one of side 2 s (s sqrt 6 rounded: 4 s^2). The glossy LOD is "
            "McGuire's (lobe solid angle = texel solid angle) on every parameterization: on the maps the level "
            "is chosen per lookup so that its texel covers the cube's mean texel solid angle at that LOD. The "
            "sphere map's capture view is the render camera unless turned (table 3). Solid-angle ratios are over "
            "the texels wholly inside the map's disc (rim texels cut by the disc are smaller); stretch is the "
            "ratio of the principal stretches of the mapping at those texels' centres (1: conformal). Frame ms: "
            "the map refilled and box-filtered every frame, SH projection, shading pass (llvmpipe, noisy).")
    md = ("\n".join(f"- {f}" for f in findings) + "\n\n" + md_table(t1_head, t1) + "\n\n" + md_table(t2_head, t2)
          + "\n\n" + md_table(t3_head, t3) + "\n\n" + md_table(t4_head, t4) + "\n\n" + note)
    blocks = [bullets(findings), table(t1_head, t1), figure(figs["psnr"], "E9 budgets"), table(t2_head, t2),
              figure(figs["rates"], "E9 sampling rates"), figure(figs["heat"], "E9 heat maps"), table(t3_head, t3),
              figure(figs["angle"], "E9 capture angle"), table(t4_head, t4), paragraph(note)]
    return Section(TITLE, blocks, md, list(figs.values()))


def store_size(param: str, face: int) -> tuple[int, int]:
    if param == "cube":
        return face, 6 * face * face
    mod = paraboloid if param == "dual_paraboloid" else spheremap
    m = mod.map_size(face)
    return m, mod.texel_count(m)


# ----------------------------------------------------------------------------- heat maps


ANGLE_EDGES = np.linspace(0.0, 180.0, 19)


@dataclass
class Heat:
    """One heat-map panel: the display-space error image (NaN off the object), the RMS error per band of
    the angle between the mirror direction and the direction back at the camera (ANGLE_EDGES), the row,
    and the panel it is compared with (None: none)."""

    title: str
    image: np.ndarray
    bands: list[float | None]
    row: ResultRow
    baseline: str | None
    shown: bool = True


def heat_maps(context: Context, s: Settings, budget_rows: dict, angle_rows: dict) -> dict[str, Heat]:
    """The mirror sphere at the heat-map budget (dual paraboloid and sphere map compared with the cube),
    and the sphere map captured from behind (compared with the one made for the render view)."""
    panels = [(LABELS[p], budget_rows[(MIRROR[0], s.heat_budget, p)], None if p == "cube" else LABELS["cube"], True)
              for p in PARAMS if (MIRROR[0], s.heat_budget, p) in budget_rows]
    front, back = angle_rows.get((MIRROR[0], min(s.angles))), angle_rows.get((MIRROR[0], max(s.angles)))
    if front is not None and back is not None and max(s.angles) > min(s.angles):
        same = f"sphere map captured {min(s.angles):g} deg away (s = {s.angle_budget})"
        panels.append((same, front, None, False))
        panels.append((f"sphere map captured {max(s.angles):g} deg away (s = {s.angle_budget})", back, same, True))
    out = {}
    for title, row, baseline, shown in panels:
        sc, mask, err = context.error_of(row)  # as the row measured it: nothing rendered again
        hits = raycast.cast(sc, 1)
        n, v = hits.normal[..., 0, :], -hits.direction[..., 0, :]
        r = 2.0 * np.sum(n * v, -1, keepdims=True) * n - v
        to_camera = np.asarray(sc.camera.origin, dtype=np.float64) - np.asarray(sc.camera.target, dtype=np.float64)
        to_camera /= np.linalg.norm(to_camera)
        angle = np.degrees(np.arccos(np.clip(r @ to_camera, -1.0, 1.0)))
        bands = []
        for lo, hi in zip(ANGLE_EDGES[:-1], ANGLE_EDGES[1:], strict=True):
            sel = mask & (angle >= lo) & (angle < hi)
            bands.append(float(np.sqrt(np.mean(err[sel] ** 2))) if sel.sum() >= 5 else None)
        out[title] = Heat(title, np.where(mask, err, np.nan), bands, row, baseline, shown)
    return out


# ----------------------------------------------------------------------------- figures


def plot_budgets(rows: dict, s: Settings, path) -> None:
    plt = plots.pyplot()
    fig, axes = plt.subplots(1, len(SCENES), figsize=(4.4 * len(SCENES), 3.6), squeeze=False)
    for ax, (label, _, _) in zip(axes[0], SCENES, strict=True):
        for p in PARAMS:
            pts = [(face, rows[(label, face, p)].psnr) for face in s.budgets if rows[(label, face, p)].psnr is not None]
            ax.plot([a for a, _ in pts], [b for _, b in pts], "o-", label=LABELS[p])
        floor = [rows[(label, face, "cube")].noise_floor_psnr for face in s.budgets]
        if floor and floor[0] is not None:
            ax.axhline(floor[0], color="grey", lw=0.8, ls=":", label="reference noise floor")
        ax.set_xscale("log", base=2)
        ax.set_xlabel("budget: cube face s (6 s² texels)")
        ax.set_ylabel("PSNR (dB)")
        ax.set_title(label)
        ax.grid(alpha=0.3, which="both")
        ax.legend(fontsize=7)
    plots.save(fig, path)


def plot_rates(rates: dict, path) -> None:
    plt = plots.pyplot()
    fig, ax = plt.subplots(1, 2, figsize=(9.6, 3.6))
    faces = sorted(rates)
    for p in PARAMS:
        xs = [next(x for x in rates[f] if x["param"] == p) for f in faces]
        line = ax[0].plot(faces, [x["ratio"] for x in xs], "o-", label=LABELS[p])[0]
        ax[0].axhline(xs[0]["limit"], color=line.get_color(), ls=":", lw=0.8)
        ax[1].plot(faces, [x["stretch"] for x in xs], "o-", label=LABELS[p], color=line.get_color())
    ax[0].set_ylabel("max / min texel solid angle (dotted: limit)")
    ax[1].set_ylabel("largest stretch (anisotropy)")
    ax[1].set_yscale("log")
    for a in ax:
        a.set_xscale("log", base=2)
        a.set_xlabel("budget: cube face s")
        a.grid(alpha=0.3, which="both")
        a.legend(fontsize=7)
    plots.save(fig, path)


def plot_heat(heat: dict[str, Heat], s: Settings, path) -> None:
    shown = [h for h in heat.values() if h.shown]
    if not shown:
        return
    plt = plots.pyplot()
    n = len(shown)
    fig, axes = plt.subplots(2, n, figsize=(3.3 * n, 6.4), squeeze=False, gridspec_kw={"height_ratios": [1.15, 1.0]})
    vmax = max(float(np.nanpercentile(h.image, 99)) for h in shown) or 1.0
    centres = 0.5 * (ANGLE_EDGES[:-1] + ANGLE_EDGES[1:])

    def line(ax, bands, *args, **kwargs):
        pts = [(c, b) for c, b in zip(centres, bands, strict=True) if b is not None]
        ax.plot([c for c, _ in pts], [b for _, b in pts], *args, **kwargs)

    for j, h in enumerate(shown):
        ax = axes[0, j]
        im = ax.imshow(h.image, cmap="magma", vmin=0.0, vmax=vmax)
        ax.set_title(f"{h.title}\nPSNR {f2(h.row.psnr)} dB", fontsize=8)
        ax.axis("off")
        line(axes[1, j], h.bands, "o-", ms=3, label="this panel")
        if h.baseline in heat:
            line(axes[1, j], heat[h.baseline].bands, "--", color="grey", lw=1.0, label=h.baseline)
        axes[1, j].set_xlabel("mirror direction from the view (deg)")
        axes[1, j].set_ylabel("RMS display error")
        axes[1, j].set_xlim(0, 180)
        axes[1, j].grid(alpha=0.3)
        axes[1, j].legend(fontsize=6)
    fig.colorbar(im, ax=list(axes[0]), shrink=0.7, label="|display error|")
    fig.suptitle(f"Mirror sphere (N = 1e4) at budget s = {s.heat_budget} (unless marked): where the error goes",
                 fontsize=9)
    fig.savefig(path, dpi=90)
    plt.close(fig)


def plot_angles(angle_rows: dict, budget_rows: dict, s: Settings, path) -> None:
    plt = plots.pyplot()
    fig, ax = plt.subplots(figsize=(6.4, 3.8))
    for label, _, _ in (MIRROR, GLOSSY):
        pts = [(a, angle_rows[(label, a)].psnr) for a in s.angles if angle_rows[(label, a)].psnr is not None]
        line = ax.plot([a for a, _ in pts], [p for _, p in pts], "o-", label=f"sphere map, {label}")[0]
        cube = budget_rows.get((label, s.angle_budget, "cube"))
        if cube is not None and cube.psnr is not None:
            ax.axhline(cube.psnr, color=line.get_color(), ls=":", lw=0.9, label=f"cube, {label}")
    ax.set_xlabel("angle between capture and render view (deg)")
    ax.set_ylabel("PSNR (dB)")
    ax.set_title(f"Sphere map view dependence (budget s = {s.angle_budget})")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7)
    plots.save(fig, path)


# ----------------------------------------------------------------------------- findings


def summarize(budget_rows, angle_rows, vertex_rows, rates, heat, s: Settings) -> list[str]:
    out = []
    for label, _, _ in SCENES:
        parts = []
        for face in s.budgets:
            cells = ", ".join(f"{LABELS[p]} {f2(budget_rows[(label, face, p)].psnr)}" for p in PARAMS)
            parts.append(f"s = {face}: {cells}")
        out.append(f"{label}, PSNR dB at matched budgets: " + "; ".join(parts) + ".")
    face = max(rates)
    out.append(f"Texel solid angle max/min at budget s = {face}: " + ", ".join(
        f"{LABELS[x['param']]} {x['ratio']:.3f} (limit {x['limit']:.3f}, largest stretch {x['stretch']:.3g})"
        for x in rates[face]) + ".")
    for label, _, _ in (MIRROR, GLOSSY):
        cells = ", ".join(f"{a:g} deg {f2(angle_rows[(label, a)].psnr)} dB" for a in s.angles)
        out.append(f"Sphere map (s = {s.angle_budget}) against the capture angle, {label}: {cells}.")
    for h in heat.values():
        if not h.shown:
            continue
        base = heat.get(h.baseline)
        if base is None:
            valid = [(b, i) for i, b in enumerate(h.bands) if b is not None]
            if valid:
                b, i = max(valid)
                out.append(f"Mirror sphere, {h.title} (s = {s.heat_budget}): the error peaks where the mirror "
                           f"direction is {ANGLE_EDGES[i]:.0f}-{ANGLE_EDGES[i + 1]:.0f} degrees from the view "
                           f"(RMS {b:.3f}).")
            continue
        ratio = [(b / c, i) for i, (b, c) in enumerate(zip(h.bands, base.bands, strict=True)) if b is not None and c]
        if ratio:
            (hi, i), (lo, k) = max(ratio), min(ratio)
            out.append(f"Mirror sphere, {h.title}: against the {base.title}, its error is largest where the mirror "
                       f"direction is {ANGLE_EDGES[i]:.0f}-{ANGLE_EDGES[i + 1]:.0f} degrees from the view (RMS "
                       f"{h.bands[i]:.3f}, {hi:.2f}x) and smallest at {ANGLE_EDGES[k]:.0f}-{ANGLE_EDGES[k + 1]:.0f} "
                       f"degrees ({lo:.2f}x).")
    for label, _, _ in vertex_scenes(s):
        for p in s.vertex_params:
            a, b = vertex_rows[(label, p, "per_pixel")], vertex_rows[(label, p, "per_vertex")]
            if a.psnr is not None and b.psnr is not None:
                out.append(f"{label}, {LABELS[p]}: per-vertex reflection {b.psnr - a.psnr:+.2f} dB against "
                           f"per-pixel ({f2(b.psnr)} vs {f2(a.psnr)}).")
    return out
