"""Pack what a bare GPU machine lacks to run iblcheck's timing experiments, into `.gpu/` (git-ignored).

The GPU machine has Python 3.12 with numpy, scipy, scikit-image, matplotlib, jinja2 and rich
(device_packages.txt lists its packages) but reaches no package registry. This script, run here where
PyPI is reachable, writes:

    .gpu/payload/wheels/*.whl   iblcheck's own wheel (this checkout), and the manylinux cp312 wheels of its
                                dependencies that the machine lacks
    .gpu/payload/gl/*.deb       the GL loader libraries (libglvnd, libEGL, libOpenGL) the machine lacks
    .gpu/payload/cache/         reference-cache entries to carry (--cache-from; optional: references are
                                keyed by Mitsuba's variant, so a GPU run renders its own with cuda_ad_rgb)
    .gpu/part-NN/payload.part   the payload as one tar cut into parts of at most --part-mib: one transfer
                                carries at most 64 MiB with the tree, and Mitsuba's wheel alone is 60 MB,
                                so each part travels in its own call while the machine stays warm
    .gpu/manifest.json          what was packed: versions, files, the parts and the tar's SHA-256

The versions are those of this checkout's virtual environment (the ones the tests passed with), so the
GPU rows come from the same code and libraries as the llvmpipe rows.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import re
import shutil
import subprocess
import sys
import tempfile
from importlib import metadata
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]
#: what iblcheck imports at run time beyond the GPU machine's own packages (pyproject's dependencies)
NEEDED = ("mitsuba", "drjit", "moderngl", "glcontext", "OpenEXR", "flip-evaluator", "trimesh", "embreex",
          "dask", "distributed")
#: what the real-time renderer alone imports (benchmarks/gpu/e10_frames.py): no path tracer, no Dask, so the
#: payload fits one transfer with the tree and the whole run is one call
REALTIME_NEEDED = ("moderngl", "glcontext", "OpenEXR", "flip-evaluator", "trimesh", "embreex")
PLATFORMS = ("manylinux_2_28_x86_64", "manylinux_2_27_x86_64", "manylinux_2_17_x86_64", "manylinux2014_x86_64",
             "manylinux_2_5_x86_64", "manylinux1_x86_64")
GL_DEBS = ("libglvnd0", "libegl1", "libopengl0", "libgl1", "libglx0", "libgles2")


def canonical(name: str) -> str:
    """PEP 503 normalised project name (a wheel's file name uses underscores)."""
    return re.sub(r"[-_.]+", "-", name).lower()


def device_packages(path: Path = HERE / "device_packages.txt") -> set[str]:
    return {canonical(line.split("#")[0].strip()) for line in path.read_text().splitlines()
            if line.split("#")[0].strip()}


def pinned(names: tuple[str, ...]) -> list[str]:
    """name==version of each package as installed in this environment."""
    return [f"{n}=={metadata.version(n)}" for n in names]


def wheel_project(path: Path) -> str:
    return canonical(path.name.split("-")[0])


def download_wheels(requirements: list[str], dest: Path) -> None:
    cmd = [sys.executable, "-m", "pip", "download", "--quiet", "--only-binary=:all:", "--python-version", "3.12",
           "--implementation", "cp", "-d", str(dest)]
    for p in PLATFORMS:
        cmd += ["--platform", p]
    subprocess.run(cmd + requirements, check=True)


def download_debs(dest: Path) -> None:
    dest.mkdir(parents=True, exist_ok=True)
    subprocess.run(["apt-get", "download", *GL_DEBS], cwd=dest, check=True, stdout=subprocess.DEVNULL)


def split(path: Path, folder: Path, part_bytes: int) -> list[Path]:
    """`path` cut into folder/part-NN/payload.part files of at most part_bytes each."""
    parts = []
    with path.open("rb") as f:
        for i in range(10**6):
            block = f.read(part_bytes)
            if not block:
                break
            part = folder / f"part-{i:02d}" / "payload.part"
            part.parent.mkdir(parents=True, exist_ok=True)
            part.write_bytes(block)
            parts.append(part)
    return parts


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", type=Path, default=ROOT / ".gpu")
    ap.add_argument("--part-mib", type=float, default=40.0, help="largest part carried in one transfer (MiB)")
    ap.add_argument("--cache-from", type=Path, help="a reference cache folder whose entries to carry")
    ap.add_argument("--no-debs", action="store_true", help="skip the GL loader packages (apt-get download)")
    ap.add_argument("--realtime-only", action="store_true",
                    help="only what the real-time renderer needs (no Mitsuba, Dr.Jit or Dask): 18 MiB, one part at "
                         "the default --part-mib")
    args = ap.parse_args(argv)

    out: Path = args.out
    shutil.rmtree(out, ignore_errors=True)
    payload = out / "payload"
    (payload / "wheels").mkdir(parents=True)
    present = device_packages()
    needed = REALTIME_NEEDED if args.realtime_only else NEEDED
    with tempfile.TemporaryDirectory() as tmp:
        download_wheels(pinned(needed), Path(tmp))
        for w in Path(tmp).glob("*.whl"):
            if wheel_project(w) not in present:
                shutil.copy2(w, payload / "wheels" / w.name)
    # iblcheck itself: its package metadata registers the builtin techniques (entry points)
    subprocess.run([sys.executable, "-m", "pip", "wheel", "--quiet", "--no-deps",
                    "-w", str(payload / "wheels"), str(ROOT)], check=True)
    if not args.no_debs:
        download_debs(payload / "gl")
    if args.cache_from:
        shutil.copytree(args.cache_from, payload / "cache", ignore=shutil.ignore_patterns("*.lock", ".*"))
    tar = out / "payload.tar"
    subprocess.run(["tar", "-cf", str(tar), "-C", str(payload), "."], check=True)
    digest = hashlib.sha256(tar.read_bytes()).hexdigest()
    parts = split(tar, out, int(args.part_mib * 2**20))
    tar.unlink()
    manifest = {
        "python": "3.12",
        "versions": {n: metadata.version(n) for n in needed},
        "realtime_only": args.realtime_only,
        "wheels": sorted(w.name for w in (payload / "wheels").glob("*.whl")),
        "gl_debs": sorted(p.name for p in (payload / "gl").glob("*.deb")),
        "cache_entries": len(list((payload / "cache").glob("*.npz"))) if args.cache_from else 0,
        "parts": [str(p.relative_to(out)) for p in parts],
        "sha256": digest,
    }
    (out / "manifest.json").write_text(json.dumps(manifest, indent=1) + "\n")
    shutil.rmtree(payload)
    for p in parts:
        print(f"{p.relative_to(ROOT)}: {p.stat().st_size / 2**20:.1f} MiB")
    print(f"{len(manifest['wheels'])} wheels, {len(manifest['gl_debs'])} GL packages, "
          f"{manifest['cache_entries']} cache entries; sha256 {digest[:16]}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
