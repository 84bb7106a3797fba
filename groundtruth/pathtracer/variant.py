"""Choosing and importing Mitsuba's variant safely (docs/contract.md section 8).

Order: `IBLCHECK_VARIANT` if set; else `cuda_ad_rgb` when an NVIDIA GPU works; else
`llvm_ad_rgb` when a libLLVM of version 16 or newer is found; else `scalar_rgb` with a warning.

drjit loads libLLVM lazily and, left alone, picks the system's default, which on Debian 12 is
LLVM 15: that one aborts the whole process ("Cannot select: fminimum"). So
`DRJIT_LIBLLVM_PATH` is pointed at a newer library *before* Mitsuba is imported, and the llvm
variant is never chosen without one.
"""

from __future__ import annotations

import glob
import os
import re
import shutil
import subprocess
import warnings
from functools import lru_cache

from scenes.storage.errors import MissingCapability

MIN_LLVM = 16
_SEARCH = ["/usr/lib/*/libLLVM-*.so*", "/usr/lib/*/libLLVM.so.*", "/usr/lib/llvm-*/lib/libLLVM*.so*",
           "/usr/lib64/libLLVM*.so*", "/usr/local/lib/libLLVM*.so*", "/opt/homebrew/opt/llvm/lib/libLLVM.dylib"]


def llvm_version(path: str) -> int | None:
    """Major version from a libLLVM file name (libLLVM-19.so, libLLVM.so.19.1, llvm-17/...)."""
    name = os.path.basename(path)
    m = re.search(r"libLLVM-(\d+)", name) or re.search(r"libLLVM\.so\.(\d+)", name)
    if not m:
        m = re.search(r"llvm-(\d+)", path)
    return int(m.group(1)) if m else None


def find_libllvm() -> str | None:
    """The newest libLLVM >= 16 on this machine (an explicit DRJIT_LIBLLVM_PATH wins if usable)."""
    env = os.environ.get("DRJIT_LIBLLVM_PATH")
    if env and os.path.exists(env) and (llvm_version(env) or MIN_LLVM) >= MIN_LLVM:
        return env
    found = [(llvm_version(p), p) for pattern in _SEARCH for p in glob.glob(pattern)]
    found = [(v, p) for v, p in found if v is not None and v >= MIN_LLVM]
    return max(found)[1] if found else None


def _nvidia_gpu_present() -> bool:
    if not shutil.which("nvidia-smi"):
        return False
    try:
        return subprocess.run(["nvidia-smi", "-L"], capture_output=True, timeout=10).returncode == 0
    except (OSError, subprocess.TimeoutExpired):
        return False


def candidate_variants() -> list[str]:
    """Variants to try, best first (the first one that loads is used)."""
    forced = os.environ.get("IBLCHECK_VARIANT")
    if forced:
        return [forced]
    out = ["cuda_ad_rgb"] if _nvidia_gpu_present() else []
    if find_libllvm() is not None:
        out.append("llvm_ad_rgb")
    out.append("scalar_rgb")
    return out


@lru_cache(maxsize=1)
def mitsuba():
    """Import Mitsuba with the first working variant set; returns the `mitsuba` module.

    Falling back (a failed CUDA start, no libLLVM >= 16) is never silent: it warns.
    """
    try:
        import drjit  # noqa: F401  (imported first only to fail early with a clear message)
    except ImportError as exc:
        raise MissingCapability(f"drjit is not installed ({exc})", "run `make setup`") from None
    errors = []
    for variant in candidate_variants():
        if variant.startswith("llvm"):
            lib = find_libllvm()
            if lib is None:
                raise MissingCapability(f"variant {variant} needs libLLVM >= {MIN_LLVM} (Debian 12's LLVM 15 aborts)",
                                        "install Debian's libllvm19 (apt-get install libllvm19)")
            os.environ["DRJIT_LIBLLVM_PATH"] = lib
        import mitsuba as mi  # deferred: heavy, and libLLVM must be found before it loads

        try:
            mi.set_variant(variant)
        except (ImportError, AttributeError, RuntimeError) as exc:
            errors.append(f"{variant}: {exc}")
            continue
        if variant == "scalar_rgb" and not os.environ.get("IBLCHECK_VARIANT"):
            warnings.warn(f"no libLLVM >= {MIN_LLVM} found: Mitsuba falls back to scalar_rgb (about 10x slower); "
                          "install Debian's libllvm19", stacklevel=2)
        elif errors:
            warnings.warn(f"Mitsuba fell back to {variant} ({'; '.join(errors)})", stacklevel=2)
        return mi
    raise MissingCapability("no Mitsuba variant could be started: " + "; ".join(errors),
                            "set IBLCHECK_VARIANT=scalar_rgb or install libllvm19")


def variant_name() -> str:
    return mitsuba().variant()
