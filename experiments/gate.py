"""`iblcheck gate`: the CI image-quality gate.

Thresholds per scene: the command line's (`--min-psnr`, `--min-ssim`, `--max-flip`) override
the scene's `[gate]` table. A scene with no threshold at all is a usage error (a gate that
cannot fail is no gate). Exit code 0 when every check passes, 1 when any fails (design.md
section 6); bad scenes are refused before anything renders (exit 2). `--junit FILE` writes JUnit
XML: one test case per scene, a <failure> naming each failed metric; names are cleaned of control
characters (experiments/text.py: XML 1.0 cannot hold them) and the file is written atomically.
"""

from __future__ import annotations

import time
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path

from scenes import InputError

from .text import one_line, xml_text

CHECKS = (("min_psnr", "psnr", ">="), ("min_ssim", "ssim", ">="), ("max_flip", "flip", "<="))


@dataclass
class GateResult:
    scene: str
    metrics: dict
    thresholds: dict
    failures: list[str] = field(default_factory=list)
    seconds: float = 0.0

    @property
    def passed(self) -> bool:
        return not self.failures


def thresholds_for(scene, cli: dict) -> dict:
    out = {k: getattr(scene.gate, k) for k, _, _ in CHECKS}
    out.update({k: v for k, v in cli.items() if v is not None})
    out = {k: v for k, v in out.items() if v is not None}
    if not out:
        raise InputError(f"{scene.path}: no gate thresholds: give --min-psnr/--min-ssim/--max-flip "
                         "or a [gate] table in the scene")
    return out


def evaluate(metrics: dict, thresholds: dict) -> list[str]:
    failures = []
    for key, metric, op in CHECKS:
        if key not in thresholds:
            continue
        value, limit = metrics.get(metric), thresholds[key]
        if value is None:
            failures.append(f"{metric} undefined (no covered pixels), required {op} {limit:g}")
        elif (op == ">=" and value < limit) or (op == "<=" and value > limit):
            failures.append(f"{metric} = {value:.4g}, required {op} {limit:g}")
    return failures


def run(scene_specs: list[str], cli_thresholds: dict, sets: dict | None = None) -> list[GateResult]:
    """Load every scene first (bad input fails before any render), then compare each."""
    return compare_all(load(scene_specs, cli_thresholds, sets))


def load(scene_specs: list[str], cli_thresholds: dict, sets: dict | None = None) -> list[tuple]:
    """[(scene, thresholds)]: every scene loaded and validated, with its thresholds."""
    import scenes

    loaded = []
    for spec in scene_specs:
        s = scenes.load(spec)
        s = s.with_overrides(sets) if sets else s
        loaded.append((s, thresholds_for(s, cli_thresholds)))
    return loaded


def compare_all(loaded: list[tuple]) -> list[GateResult]:
    from . import comparison

    results = []
    for s, th in loaded:
        t0 = time.perf_counter()
        c = comparison.run(s)
        results.append(GateResult(s.name, c.metrics, th, evaluate(c.metrics, th), time.perf_counter() - t0))
    return results


def format_table(results: list[GateResult]) -> str:
    lines = [f"{'scene':<22} {'result':<6} {'PSNR':>7} {'SSIM':>7} {'FLIP':>7}  checks"]
    for r in results:
        def f(key, spec, m=r.metrics):
            return "-" if m.get(key) is None else format(m[key], spec)

        checks = ", ".join(f"{k}={v:g}" for k, v in r.thresholds.items())
        lines.append(f"{one_line(r.scene, 60):<22} {'PASS' if r.passed else 'FAIL':<6} {f('psnr', '.2f'):>7} "
                     f"{f('ssim', '.4f'):>7} "
                     f"{f('flip', '.4f'):>7}  {checks}")
        lines += [f"    - {msg}" for msg in r.failures]
    n_fail = sum(not r.passed for r in results)
    lines.append(f"{len(results) - n_fail} passed, {n_fail} failed")
    return "\n".join(lines)


def write_junit(path: Path, results: list[GateResult]) -> None:
    suite = ET.Element("testsuite", name="iblcheck gate", tests=str(len(results)),
                       failures=str(sum(not r.passed for r in results)), errors="0",
                       time=f"{sum(r.seconds for r in results):.3f}")
    for r in results:
        case = ET.SubElement(suite, "testcase", classname="iblcheck.gate", name=xml_text(r.scene),
                             time=f"{r.seconds:.3f}")
        props = ET.SubElement(case, "properties")
        for k in ("psnr", "ssim", "flip", "noise_floor_psnr"):
            value = r.metrics.get(k)
            ET.SubElement(props, "property", name=k, value="null" if value is None else f"{value:.6g}")
        if r.failures:
            fail = ET.SubElement(case, "failure", message=xml_text("; ".join(r.failures)), type="ImageQuality")
            fail.text = "\n".join(xml_text(f) for f in r.failures)
    root = ET.Element("testsuites", name="iblcheck")
    root.append(suite)
    from .outputs import write_bytes

    write_bytes(path, ET.tostring(root, encoding="utf-8", xml_declaration=True))
