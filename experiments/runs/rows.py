"""One result row: its content id, and the row runner that renders, measures and pictures a configuration.

    content_id(scene, reference_only=False) -> str       # the row's identity (and the reference's)
    row_id(spec, overrides) -> str                        # the same, from a scene as named
    run_row(out_dir, spec, overrides, ...) -> ResultRow   # render, measure once, save the pictures
    measured_row(out_dir, spec, overrides, scene, ...)    # the row of a pair measured already (compare, gate)

Both executors use this module: the serial loop of experiments/runs/sweep.py and the Dask driver of
experiments/runs/dask_cluster.py (which renders the references on workers and hands them to `run_row`).

Row ids are keyed by content, like the reference cache: a hash of the resolved scene (every key with
its default filled in, `to_dict`), the bytes of a map file and of mesh files (not their paths), the
light array's directions and powers when the reference is rendered with it (`reference.lighting =
"light_array"`), and ROW_VERSION and the reference plugin's version (`content_id`).

Every measurement of a row comes from one `experiments.measure.pair.measure_pair` of its images; the
pictures and the arrays the paper's figures read (`experiments.publish.images.save_comparison`) are
made from that measurement, never from a second render or a second FLIP.
"""

from __future__ import annotations

import hashlib
import json
import socket
from dataclasses import replace
from functools import lru_cache
from pathlib import Path
from typing import Any

import numpy as np

import scenes
from experiments.measure import comparison, convergence
from experiments.measure.pair import Measurement
from experiments.measure.results import ResultRow
from experiments.publish import images
from experiments.publish.text import one_line
from groundtruth.pathtracer import gltf_pbr_bsdf, paper_bsdf
from realtime.engine import technique
from realtime.engine.context import renderer_name
from scenes.environment import light_array
from scenes.geometry.meshes import BUILTIN_MESHES
from scenes.model import materials, technique_registry
from scenes.model.render import Render

#: bump when what a row measures changes for the same scene (it is part of every row id)
ROW_VERSION = 3


@lru_cache(maxsize=64)
def _file_digest(path: str, mtime_ns: int, size: int) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def file_digest(path: str) -> str:
    """SHA-256 of a file's bytes, cached per (path, modification time, size)."""
    st = Path(path).stat()
    return _file_digest(str(path), st.st_mtime_ns, st.st_size)


def scene_content(scene, reference_only: bool = False) -> dict:
    """What determines a row of `scene`: the resolved scene with file paths replaced by digests of
    their content (a map's bytes, a mesh's arrays as read); the [gate] table is left out (it changes no
    measurement). `reference_only` keeps what the reference depends on (no [realtime], no tone mapping)."""
    d = scene.content_dict()
    d.pop("path", None)
    d.pop("gate", None)
    env = d["environment"]
    if not scene.environment.builtin_name:
        env["map"] = {"sha256": file_digest(scene.environment.map)}
    for obj, od in zip(scene.objects, d["objects"], strict=True):
        if obj.shape not in BUILTIN_MESHES:
            # the mesh as read, not the file's bytes: a .gltf's buffers live in other files
            h = hashlib.sha256()
            for arr in (obj.mesh.positions, obj.mesh.normals, obj.mesh.indices):
                h.update(np.ascontiguousarray(arr).tobytes())
            od["shape"] = {"mesh_sha256": h.hexdigest()}
    if scene.reference.lighting == "light_array":  # the reference renders the real-time light array: by content
        lights = scene.realtime.lights
        d["reference"]["light_array"] = {
            "placement": lights.placement, "count": lights.count,
            "sha256": light_array.content_digest(scene.environment.radiance(), lights.placement, lights.count)}
    if reference_only:
        for key in ("realtime", "tonemap", "name"):
            d.pop(key, None)
    return d


def content_id(scene, reference_only: bool = False) -> str:
    """The id of a row of `scene`: a hash of scene_content, ROW_VERSION, the reference plugins' versions and
    the chosen techniques' model versions (Declaration.model_version, where set)."""
    content = {"row": ROW_VERSION, "plugin": paper_bsdf.PLUGIN_VERSION, "scene": scene_content(scene, reference_only)}
    if any(o.material.type == "pbr" for o in scene.objects):  # absent without one: earlier rows keep their ids
        content["gltf_pbr_plugin"] = [gltf_pbr_bsdf.PLUGIN_VERSION, gltf_pbr_bsdf.SMITH]
    models = {} if reference_only else {f"{d.effect}={d.name}": d.model_version
                                        for d in technique_registry.chosen(scene.realtime) if d.model_version}
    if models:  # absent where no chosen technique has one: those rows keep their ids
        content["models"] = models
    text = json.dumps(content, sort_keys=True, default=str)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def image_row_id(scene, image: Path, encoding: str, tonemap: str, exposure: float, label: str) -> str:
    """The id of an engine image's row (experiments/runs/image_manifest.py): the scene's content id, the
    image file's SHA-256, how it is read and its label."""
    content = {"scene": content_id(scene), "image_sha256": file_digest(str(image)), "encoding": encoding,
               "tonemap": tonemap, "exposure": exposure, "label": label}
    return hashlib.sha256(json.dumps(content, sort_keys=True).encode()).hexdigest()[:16]


def row_id(scene_spec: str, overrides: dict) -> str:
    """The content id of the row (scene_spec, overrides)."""
    scene = scenes.load(scene_spec)
    return content_id(scene.with_overrides(overrides) if overrides else scene)


def materials_of(scene) -> list[dict[str, Any]]:
    """Every object's material as the row stores it: its type and the fields that type uses."""
    return [{k: (list(v) if isinstance(v, tuple) else v) for k, v in materials.used_fields(o.material).items()}
            for o in scene.objects]


def run_row(out_dir: Path, spec: str, overrides: dict, experiment: str | None = None,
            convergence_curve=None, extra: dict | None = None,
            references: tuple[Render, Render | None] | None = None) -> ResultRow:
    """Render one configuration in real time and its (cached) reference, measure the pair once, save
    the pictures and the measured arrays (`images.save_comparison`; the row's `images`).

    With a reference `convergence_curve` (experiments.measure.convergence.curve), the row gets
    `equal_quality_s`: the path tracer's time to the real-time image's unbiased PSNR.
    `references`: the (reference, noise-floor reference) Renders already rendered elsewhere (a Dask
    task, experiments/runs/dask_cluster.py); only the real-time part runs here then."""
    scene = scenes.load(spec).with_overrides(overrides)
    c = comparison.run(scene) if references is None else comparison.run(scene, *references)
    # the second seed the comparison used, for the report's viewer: a hit in the reference cache, never a render
    reference2 = references[1] if references is not None and references[1] is not None \
        else comparison.second_reference(c.reference, scene)
    row = measured_row(out_dir, spec, overrides, scene, c.metrics, c.measured, c.test, c.reference, reference2,
                       experiment=experiment, extra=extra)
    return row if convergence_curve is None else with_equal_quality(row, convergence_curve)


def measured_row(out_dir: Path, spec: str, overrides: dict, scene, m: dict, measured: Measurement, test: Render,
                 reference: Render, reference2: Render | None, experiment: str | None = None,
                 extra: dict | None = None) -> ResultRow:
    """The row of a pair measured once (`comparison.compare`'s dict `m` and its `measured`), with its
    pictures and arrays saved under out_dir/images (`images.save_comparison`: the real-time render, the
    maps, the reference's radiance and the display transform the report's viewer shows). Used by
    `run_row` and by `iblcheck compare/gate --report`, which have measured the pair already."""
    rid, ref_id = content_id(scene), content_id(scene, reference_only=True)
    pics = images.save_comparison(out_dir, out_dir / "images" / ref_id / rid, measured, test, reference, reference2,
                                  images.display_tonemap(scene))
    external = test.meta.get("renderer") == "command"  # an engine run as a command (engines/command.py)
    if external:
        techniques = {"renderer": "command", "engine": test.meta.get("engine"),
                      "engine_version": test.meta.get("engine_version")}
    else:
        techniques = test.meta.get("techniques") or technique.describe(scene)  # what ran, not_run included
    return ResultRow(
        id=rid, spec=spec, overrides=overrides, scene=scene.name, techniques=techniques,
        materials=materials_of(scene), env=scene.environment.map, effects=sorted(scene.effects),
        unsimulated_effects=m["unsimulated_effects"], width=scene.camera.width, height=scene.camera.height,
        face_size=0 if external else test.meta["face_size"], psnr=m["psnr"], ssim=m["ssim"], flip=m["flip"],
        rel_mse=m["rel_mse"],
        noise_floor_psnr=m["noise_floor_psnr"], at_noise_floor=m["at_noise_floor"], pixels=m["pixels"],
        realtime_ms=m["realtime_ms"], reference_s=m["reference_s"], reference_spp=m["reference_spp"],
        reference_id=ref_id, reference_cache=m["reference_cache"], psnr_unbiased=m["psnr_unbiased"],
        psnr_unbiased_clamped=m["psnr_unbiased_clamped"],
        realtime_p90_ms={k: test.timings.get(f"{k}_p90") for k in m["realtime_ms"] if k != "precompute"},
        experiment=experiment, host=socket.gethostname(),
        gl_renderer=(f"{techniques['engine']} {techniques['engine_version'] or ''}".strip() if external
                     else renderer_name()), images=pics, extra=extra or {})


def with_equal_quality(row: ResultRow, curve) -> ResultRow:
    """`row` with `equal_quality_s`: the path tracer's time to the row's unbiased PSNR (its plain PSNR
    where that is undefined) on a reference convergence curve (experiments.measure.convergence.curve)."""
    target = row.psnr_unbiased if row.psnr_unbiased is not None else row.psnr
    seconds, how = convergence.equal_quality_s(curve, target)
    return replace(row, equal_quality_s=seconds, equal_quality=how)


def error_row(spec: str, overrides: dict, rid: str, message: str) -> ResultRow:
    """A row for a configuration whose reference (or real-time part) failed: what the scene is, no
    metrics, `error` set. The next run computes it again."""
    scene = scenes.load(spec).with_overrides(overrides)
    face = scene.realtime.face_size
    return ResultRow(
        id=rid, spec=spec, overrides=overrides, scene=scene.name, techniques=technique.describe(scene),
        materials=materials_of(scene), env=scene.environment.map, effects=sorted(scene.effects),
        unsimulated_effects=[], width=scene.camera.width, height=scene.camera.height,
        face_size=face if isinstance(face, int) else 0, psnr=None, ssim=None, flip=None, rel_mse=None,
        noise_floor_psnr=None, at_noise_floor=None, pixels=0, realtime_ms={"filter": None, "draw": None, "total": None},
        reference_id=content_id(scene, reference_only=True), host=socket.gethostname(), error=one_line(message, 600))


def short(overrides: dict) -> str:
    """The overrides of a row in a few words for a progress bar (camera and reference keys left out)."""
    return " ".join(f"{k.split('.')[-1]}={v}" for k, v in overrides.items()
                    if not k.startswith(("camera.", "reference.")))
