"""Manifests of engine images: `iblcheck gate --images MANIFEST` and `iblcheck sweep --images MANIFEST`.

A manifest (TOML or JSON) lists the images another renderer made of iblcheck's scenes:

    [[images]]
    scene = "builtin:sphere-diffuse"     # or a scene file, relative to the manifest
    image = "out/sphere.exr"             # relative to the manifest
    encoding = "linear"                  # optional: linear (EXR/PFM/HDR default) | srgb (PNG/JPEG: required)
    tonemap = "none"                     # the engine's operator (srgb), scenes/model/tone_operators.py, or
                                         # "scene": the scene's own display transform (iblcheck render's PNG)
    exposure = 1.0                       # the engine's exposure (srgb)
    label = "threejs"                    # optional: the image file's stem; scene + label is the baseline key

(JSON: {"images": [{...}, ...]}.) Every entry is read and checked (scene, image file, size, pixels) before
anything renders; an error names the manifest, the entry's index and key. The gate judges each image
against its scene's reference with the scene's thresholds, the baseline (keyed `SCENE#LABEL`), JUnit
and Markdown as for iblcheck's own renders; the sweep appends one result row per entry.
"""

from __future__ import annotations

import json
import socket
import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from experiments.measure import comparison, engine_image
from experiments.measure.results import ResultRow
from experiments.publish import images
from experiments.runs.gate import Planned, scene_key, thresholds_for
from experiments.runs.rows import content_id, file_digest, image_row_id, materials_of
from scenes import InputError
from scenes.exchange import scene_spec
from scenes.storage.files import read_input

MAX_MANIFEST_BYTES = 4 << 20
KEYS = ("scene", "image", "encoding", "tonemap", "exposure", "label")


@dataclass(frozen=True)
class Entry:
    """One manifest entry, resolved: the scene as named, the image path, how to read it, its label."""

    index: int
    spec: str
    image: Path
    encoding: str
    tonemap: str
    exposure: float
    label: str

    @property
    def key(self) -> str:
        """The baseline key: the scene's key and the label."""
        return f"{scene_key(self.spec)}#{self.label}"


def read_manifest(path: str | Path) -> list[Entry]:
    """The entries of a manifest file, checked (module docstring); InputError naming file, index, key."""
    path = Path(path)
    data = read_input(path, "image manifest", MAX_MANIFEST_BYTES, InputError)
    try:
        text = data.decode("utf-8")
        tree = json.loads(text) if path.suffix.lower() == ".json" else tomllib.loads(text)
    except (UnicodeDecodeError, ValueError) as exc:  # tomllib.TOMLDecodeError and JSONDecodeError are ValueErrors
        raise InputError(f"{path}: image manifest is not valid {'JSON' if path.suffix.lower() == '.json' else 'TOML'}"
                         f" ({exc})") from None
    items = tree.get("images") if isinstance(tree, dict) else None
    if not isinstance(items, list) or not items:
        raise InputError(f"{path}: images: a manifest lists its entries under `images` ([[images]] tables in TOML, "
                         "a list of objects in JSON), at least one")
    out, keys = [], {}
    for i, item in enumerate(items):
        entry = _entry(path, i, item)
        if entry.key in keys:
            raise InputError(f"{path}: images[{i}].label: {entry.label!r} repeats images[{keys[entry.key]}] of the "
                             "same scene; give each image of a scene its own label")
        keys[entry.key] = i
        out.append(entry)
    return out


def _entry(path: Path, i: int, item: Any) -> Entry:
    where = f"{path}: images[{i}]"
    if not isinstance(item, dict):
        raise InputError(f"{where}: must be a table of {', '.join(KEYS)}")
    unknown = sorted(set(item) - set(KEYS))
    if unknown:
        raise InputError(f"{where}.{unknown[0]}: unknown key; an entry has {', '.join(KEYS)}")
    for key in ("scene", "image"):
        if not isinstance(item.get(key), str) or not item[key].strip():
            raise InputError(f"{where}.{key}: missing or not a string")
    spec = item["scene"]
    if not spec.startswith("builtin:"):
        spec = str(path.parent / spec)
    image = path.parent / item["image"]
    encoding = item.get("encoding", engine_image.default_encoding(image))
    if encoding not in engine_image.ENCODINGS:
        raise InputError(f"{where}.encoding: {encoding!r}; choose linear or srgb (a PNG or JPEG must say srgb)"
                         if encoding is not None else f"{where}.encoding: missing; a PNG or JPEG must say "
                         "encoding = \"srgb\" and its tonemap")
    tonemap = item.get("tonemap", None if encoding == "srgb" else "none")
    if tonemap not in engine_image.TONEMAPS:
        raise InputError(f"{where}.tonemap: {tonemap!r}; choose one of {', '.join(engine_image.TONEMAPS)}"
                         + (" (an srgb image must name its operator)" if tonemap is None else ""))
    exposure = item.get("exposure", 1.0)
    if isinstance(exposure, bool) or not isinstance(exposure, (int, float)) or not (0 < exposure < float("inf")):
        raise InputError(f"{where}.exposure: {exposure!r}; must be a finite number > 0")
    if problem := engine_image.scene_exposure_problem(tonemap, exposure):
        raise InputError(f"{where}.exposure: {problem}")
    label = item.get("label", image.stem)
    if not isinstance(label, str) or not label.strip():
        raise InputError(f"{where}.label: {label!r}; must be a non-empty string")
    return Entry(i, spec, image, encoding, tonemap, float(exposure), label)


def load_images(manifest: str | Path, sets: dict | None = None) -> list[tuple[Entry, Any, engine_image.EngineImage]]:
    """(entry, scene, image) per entry: every scene loaded and every image read and checked before
    anything renders. An error names the manifest and the entry."""
    out = []
    for e in read_manifest(manifest):
        where = f"{manifest}: images[{e.index}]"
        try:
            scene = scene_spec.load(e.spec)
            scene = scene.with_overrides(sets) if sets else scene
        except InputError as exc:
            raise InputError(f"{where}.scene: {exc}") from None
        try:
            image = engine_image.read_engine_image(e.image, scene, e.encoding, e.tonemap, e.exposure)
        except InputError as exc:
            raise InputError(f"{where}.image: {exc}") from None
        out.append((e, scene, image))
    return out


def gate_plan(manifest: str | Path, cli_thresholds: dict, sets: dict | None = None,
              thresholds_required: bool = True) -> list[Planned]:
    """The gate's plan of a manifest: one `Planned` per image (its `image` set, its key SCENE#LABEL)."""
    return [Planned(str(e.image), scene, thresholds_for(scene, cli_thresholds, thresholds_required), dict(sets or {}),
                    e.key, image=image, label=e.label, scene_spec=e.spec)
            for e, scene, image in load_images(manifest, sets)]


def techniques_of(image: engine_image.EngineImage, label: str) -> dict:
    """A row's `techniques` for an engine image: the engine, how its file was read, its label."""
    return {"renderer": "image", "engine": image.engine or label, "engine_version": image.engine_version,
            "encoding": image.encoding, "tonemap": image.tonemap, "exposure": image.exposure, "label": label}


def image_row(out_dir: Path, entry: Entry, scene, image: engine_image.EngineImage) -> ResultRow:
    """One result row of an engine image against its scene's (cached) reference, its pictures saved."""
    c = engine_image.compare_image(image, scene)
    m = c.metrics
    rid = image_row_id(scene, image.path, image.encoding, image.tonemap, image.exposure, entry.label)
    ref_id = content_id(scene, reference_only=True)
    # a linear image is radiance like iblcheck's own: the viewer shows it beside the references, under the
    # scene's tone mapping; a tone-mapped sRGB image has no radiance to show that way (its maps only)
    linear = not image.display_space
    pics = images.save_comparison(out_dir, out_dir / "images" / ref_id / f"image-{rid}" / "engine", c.measured, c.test,
                                  c.reference if linear else None,
                                  comparison.second_reference(c.reference, scene) if linear else None,
                                  images.display_tonemap(scene) if linear else None)
    extra = {"image": {"path": str(image.path), "sha256": file_digest(str(image.path)), "label": entry.label,
                       "encoding": image.encoding, "tonemap": image.tonemap, "exposure": image.exposure,
                       **({"note": engine_image.DISPLAY_ONLY} if image.display_space else {})}}
    return ResultRow(
        id=rid, spec=entry.spec, overrides={}, scene=scene.name, techniques=techniques_of(image, entry.label),
        materials=materials_of(scene), env=scene.environment.map, effects=sorted(scene.effects),
        unsimulated_effects=[], width=scene.camera.width, height=scene.camera.height, face_size=0,
        psnr=m["psnr"], ssim=m["ssim"], flip=m["flip"], rel_mse=m["rel_mse"], noise_floor_psnr=m["noise_floor_psnr"],
        at_noise_floor=m["at_noise_floor"], pixels=m["pixels"], realtime_ms=m["realtime_ms"],
        reference_s=m["reference_s"], reference_spp=m["reference_spp"], reference_id=ref_id,
        reference_cache=m["reference_cache"], psnr_unbiased=m["psnr_unbiased"],
        psnr_unbiased_clamped=m["psnr_unbiased_clamped"], host=socket.gethostname(),
        gl_renderer=" ".join(x for x in (image.engine or entry.label, image.engine_version) if x), images=pics,
        extra=extra)
