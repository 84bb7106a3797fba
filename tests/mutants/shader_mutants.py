"""Hand-made mutants of the real-time renderer's GLSL (and of the host code that feeds it), which mutation tools
cannot mutate: each one is applied alone to a scratch copy of the working tree, the GL tests run there, and the
mutant must make them fail ("caught"). `make shader-mutants`; not part of `make test` (it takes minutes).

    python tests/mutants/shader_mutants.py [--include-golden] [--list] [NAME_SUBSTRING ...]

Each entry is (file, exact original snippet, replacement, description). A snippet that is not found exactly once
in its file stops the script before anything runs (exit 2): the shader changed, so the list must be updated
with it (never silently skipped). The unmutated copy must pass the same tests first (exit 2 otherwise).

By default the golden-image test (tests/realtime/test_golden.py, bit-identical images of the paper's method) is
left out: it would catch every mutant without saying what is wrong, and the point is that the tests with an
independent expectation catch them. `--include-golden` runs it too.

Exit status: 0 every mutant caught, 1 some survived, 2 the list or the baseline is broken.
"""

from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]

# (file, exact original snippet, replacement, description)
MUTANTS: list[tuple[str, str, str, str]] = [
    ("realtime/techniques/box/glossy_box.py", "rt.base_size, rt.lod_bias, rt.lod_mapping",
     "rt.base_size, 0.0, rt.lod_mapping",
     "ignore the LOD bias (host side: the glossy LOD reaches the shader as the uniform glossy_lod)"),
    ("realtime/techniques/box/glossy_box.glsl", "textureLod(env_cube, r, glossy_lod)", "textureLod(env_cube, r, 0.0)",
     "glossy lookup ignores its LOD (reads the base level)"),
    ("realtime/shaders/shade.frag", "if (dot(n, v) <= 0.0) {", "if (dot(n, v) <= -2.0) {",
     "drop the back-face rule (one-sided materials are black where n.v <= 0)"),
    ("realtime/shaders/shade.frag", "pow(1.0 - n_dot_v, 5.0)", "(1.0 - n_dot_v)",
     "drop the Fresnel power (Schlick's ^5)"),
    ("realtime/shaders/shade.frag", "color = (1.0 - F) * Ld + F * Lg;", "color = F * Ld + (1.0 - F) * Lg;",
     "swap the Fresnel weights of the two lobes"),
    ("realtime/shaders/shade.frag", "float F = f0 + (1.0 - f0) * pow(", "float F = (1.0 - f0) * pow(",
     "Schlick without its f0 term (F = 0 at normal incidence)"),
    ("realtime/shaders/shade.frag", "max(diffuse_irradiance(n), vec3(0.0))", "diffuse_irradiance(n)",
     "drop the max(E, 0) clamp of the SH irradiance"),
    ("realtime/shaders/shade.frag", "Ld = kd / PI * ", "Ld = kd * ", "diffuse without 1/pi"),
    ("realtime/shaders/shade.frag", "glossy_radiance(reflect(-v, n))", "glossy_radiance(reflect(v, n))",
     "reflect the wrong view vector"),
    ("realtime/shaders/sh_reduce.comp", "const float c1 = SH_M1, c2 = SH_M2,", "const float c1 = SH_M2, c2 = SH_M1,",
     "swap two SH constants (c1 <-> c2 of eq. 12)"),
    ("realtime/shaders/sh_reduce.comp", "c4 * L00 - c5 * L20", "c4 * L00 + c5 * L20",
     "sign of the c5 term of M[3][3]"),
    ("realtime/shaders/sh_project.comp", "c[1] += L * (SH_C1 * y);", "c[1] += L * (SH_C1 * x);",
     "SH basis Y1-1 on x instead of y"),
    ("realtime/shaders/sh_project.comp", "c[6] += L * (SH_C3 * (3.0 * z * z - 1.0));",
     "c[6] += L * (SH_C3 * (3.0 * y * y - 1.0));", "SH basis Y20 about y instead of z"),
    ("realtime/techniques/sh/diffuse_sh9.glsl", "vec4 n4 = vec4(n, 1.0);", "vec4 n4 = vec4(n, 0.0);",
     "n^T M n without the homogeneous 1 (drops the constant terms)"),
    ("realtime/shaders/common.glsl", "if (face == 4) return vec3(sc, -tc, 1.0);",
     "if (face == 4) return vec3(sc, tc, 1.0);", "flip a cube axis (+Z face, t)"),
    ("realtime/shaders/common.glsl", "if (face == 0) return vec3(1.0, -tc, -sc);",
     "if (face == 0) return vec3(1.0, -tc, sc);", "flip a cube axis (+X face, s)"),
    ("realtime/shaders/common.glsl", "float row = v * float(H - 1);", "float row = v * float(H) - 0.5;",
     "equirect rows as pixel centres instead of Mitsuba's align-corners"),
    ("realtime/shaders/env_to_cube.comp", "env_lookup_uv(env, uv.x + u_shift, uv.y)",
     "env_lookup_uv(env, uv.x - u_shift, uv.y)", "environment rotation with the wrong sign"),
    ("realtime/shaders/downsample.comp", "+ imageLoad(src, s + ivec3(0, 1, 0)) + imageLoad(src, s + ivec3(1, 1, 0));",
     "+ imageLoad(src, s + ivec3(1, 0, 0)) + imageLoad(src, s + ivec3(1, 1, 0));",
     "box filter reads one texel twice and skips another"),
    # the light array, its shadow maps and PRT
    ("realtime/techniques/lights/lights.glsl", "if (c > 0.0) E += light_power[i].rgb",
     "if (c > -1.0) E += light_power[i].rgb",
     "light array: lights below the surface's horizon count (negative cosines)"),
    ("realtime/techniques/lights/light_power.comp", ".rgb * row_omega[row];", ".rgb;",
     "light array powers without the texels' solid angles"),
    ("realtime/techniques/shadow_maps/shadow_maps.glsl", "    return 0.25 * v;", "    return 1.0;",
     "shadow maps never shadow"),
    ("realtime/techniques/prt/prt_vertex.glsl", "int base = gl_VertexID * SH_COUNT * 3;", "int base = 0;",
     "PRT: every vertex reads the first vertex's transfer"),
]

GL_TESTS = ["tests/realtime", "tests/hard"]
GOLDEN = "tests/realtime/test_golden.py"


def copy_tree(dst: Path) -> None:
    """Tracked and untracked, not ignored files of the working tree (what the tests see)."""
    files = subprocess.run(["git", "ls-files", "-co", "--exclude-standard", "-z"], cwd=ROOT, check=True,
                           capture_output=True).stdout.decode().split("\0")
    for name in filter(None, files):
        src = ROOT / name
        if src.is_file():
            (dst / name).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(src, dst / name)


def check_snippets(mutants) -> list[str]:
    problems = []
    for file, old, _, desc in mutants:
        path = ROOT / file
        count = path.read_text().count(old) if path.is_file() else -1
        if count != 1:
            where = "file missing" if count < 0 else f"found {count} times"
            problems.append(f"{file}: {desc}: snippet {old!r} {where}")
    return problems


def run_tests(copy: Path, include_golden: bool, stop_at_first: bool) -> tuple[int, str, float]:
    args = [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "-m", "gl and not slow", *GL_TESTS]
    if not include_golden:
        args.append(f"--ignore={GOLDEN}")
    if stop_at_first:
        args.append("-x")
    env = {**os.environ, "PYTHONPATH": str(copy)}
    t0 = time.perf_counter()
    out = subprocess.run(args, cwd=copy, env=env, capture_output=True, text=True)
    lines = [line for line in out.stdout.strip().splitlines() if line.strip()]
    failed = [line.split(" - ")[0].removeprefix("FAILED ") for line in lines if line.startswith("FAILED ")]
    summary = (failed[0] + " ... " if failed else "") + (lines[-1] if lines else out.stderr.strip()[-300:])
    return out.returncode, summary, time.perf_counter() - t0


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("names", nargs="*", help="run only mutants whose description contains one of these")
    parser.add_argument("--include-golden", action="store_true", help="also run the golden-image test")
    parser.add_argument("--list", action="store_true", help="list the mutants and check their snippets")
    args = parser.parse_args(argv)
    mutants = [m for m in MUTANTS if not args.names or any(n in m[3] for n in args.names)]
    problems = check_snippets(mutants)
    if problems:
        print("error: the mutant list no longer matches the code; update tests/mutants/shader_mutants.py:",
              *problems, sep="\n  ", file=sys.stderr)
        return 2
    if args.list:
        for file, old, new, desc in mutants:
            print(f"{desc}\n    {file}: {old!r} -> {new!r}")
        return 0
    with tempfile.TemporaryDirectory(prefix="shader-mutants-") as tmp:
        copy = Path(tmp)
        copy_tree(copy)
        where = subprocess.run([sys.executable, "-c", "import realtime; print(realtime.__file__)"], cwd=copy,
                               env={**os.environ, "PYTHONPATH": str(copy)}, capture_output=True, text=True)
        if not where.stdout.strip().startswith(str(copy)):
            print(f"error: the copy's tests would import realtime from {where.stdout.strip() or where.stderr}",
                  file=sys.stderr)
            return 2
        code, summary, secs = run_tests(copy, args.include_golden, stop_at_first=False)
        print(f"baseline (no mutant): {summary} [{secs:.0f} s]")
        if code != 0:
            print("error: the unmutated code fails these tests; fix that first", file=sys.stderr)
            return 2
        survived = []
        for file, old, new, desc in mutants:
            path = copy / file
            original = path.read_text()
            path.write_text(original.replace(old, new))
            try:
                code, summary, secs = run_tests(copy, args.include_golden, stop_at_first=True)
            finally:
                path.write_text(original)
            verdict = "caught" if code == 1 else "SURVIVED" if code == 0 else f"error (pytest exit {code})"
            if code == 0:
                survived.append(desc)
            print(f"{verdict:>9}  {desc}  [{file}; {secs:.0f} s]\n           {summary}")
        print(f"\n{len(mutants) - len(survived)} of {len(mutants)} shader mutants caught")
        return 1 if survived else 0


if __name__ == "__main__":
    sys.exit(main())
