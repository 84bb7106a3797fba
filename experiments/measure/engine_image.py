"""Any engine's image, read from its file and scored against the scene's reference.

    read_engine_image(path, scene, encoding="linear"|"srgb", tonemap="none", exposure=1.0) -> EngineImage
    measure_display_pair(image, reference, scene, second_reference=None) -> Measurement
    compare_image(image, scene, reference=None, reference2=None) -> Comparison

Two kinds of image (docs/contract.md, the display-space rule):

- **linear** (OpenEXR, PFM, Radiance .hdr): the engine's radiance, no tone mapping. It becomes a `Render`
  (rgb, mask all True: the coverage is the reference's; timings from the timings JSON beside it) and is
  measured by `measure_pair` exactly as iblcheck's own real-time image: the scene's display transform
  on both sides, every metric.
- **srgb** (PNG 8 or 16 bit, JPEG): a tone-mapped, sRGB-encoded image. The reference is put through the
  same named operator and exposure (scenes/model/tone_operators.py) and sRGB-encoded, or with the operator
  `scene` through the scene's own display transform (metrics.display, the sRGB encoding included: the PNG
  `iblcheck render` writes), then quantised to the image's bit depth; the image's code values become [0, 1];
  PSNR, SSIM and FLIP are computed on the
  common mask of those display values. The linear metrics (rel_mse, psnr_unbiased) are None:
  "display-space metrics only (the image is tone-mapped sRGB)".

A linear image is read by engines/linear_image.py, as an engine run as a command is: its OpenEXR alpha, when it
has one, is the engine's coverage (alpha >= 0.5; an alpha below 0.5 everywhere is refused: nothing would be
compared); without it the reference's coverage decides which pixels count. A PNG's alpha is ignored (a
screenshot's alpha says nothing about coverage). The timings JSON is read by engines/engine_timings.py. Every
problem with the file is a `scenes.InputError` naming it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import imageio.v3 as iio
import numpy as np

import groundtruth
from engines import engine_timings, linear_image
from experiments.measure import comparison, metrics
from experiments.measure.pair import Measurement, clipped_share, measure_pair
from scenes import InputError
from scenes.model import tone_operators
from scenes.model.render import Render
from scenes.model.tonemap import srgb_decode, srgb_encode
from scenes.storage import imageio as hdr_io
from scenes.storage import png16

ENCODINGS = ("linear", "srgb")
#: the operator naming the scene's own display transform (metrics.display: Reinhard with the scene's
#: [tonemap] key, white and exposure and its environment's adaptation luminance, then sRGB), which is what
#: the PNG of `iblcheck render` holds; its exposure is the scene's, so the image's own must stay 1
SCENE_TONEMAP = "scene"
#: the operators an sRGB image may name: an engine's (tone_operators.NAMES) or the scene's own
TONEMAPS = (*tone_operators.NAMES, SCENE_TONEMAP)
#: file suffixes per encoding
LINEAR_SUFFIXES = {".exr": hdr_io.read_exr, ".pfm": hdr_io.read_pfm, ".hdr": hdr_io.read_hdr}
DISPLAY_SUFFIXES = (".png", ".jpg", ".jpeg")
#: what the row, the table and the JSON say about a display-space comparison
DISPLAY_ONLY = "display-space metrics only (the image is tone-mapped sRGB)"
#: the timings JSON an engine may write beside its image: FRAME.exr -> FRAME.timings.json
TIMINGS_SUFFIX = ".timings.json"


@dataclass(frozen=True)
class EngineImage:
    """An engine's image as read: `values` are linear radiance (encoding "linear", float32) or the file's
    code values scaled to [0, 1] (encoding "srgb", float64, still sRGB-encoded); `bits` the sRGB file's
    bit depth (8 or 16), None for linear. `timings`: the Render timings from the timings JSON (ms)."""

    path: Path
    encoding: str
    tonemap: str
    exposure: float
    values: np.ndarray
    bits: int | None = None
    timings: dict = field(default_factory=dict)
    engine: str | None = None
    engine_version: str | None = None
    alpha_ignored: bool = False
    coverage: np.ndarray | None = None  # a linear OpenEXR's alpha >= 0.5, or None (engines/linear_image.py)

    @property
    def display_space(self) -> bool:
        return self.encoding == "srgb"

    def render(self) -> Render:
        """The image as a `Render`: the radiance (linear) or the display-linear values (srgb, for the
        timings and meta only: a display-space image is measured by `measure_display_pair`)."""
        rgb = self.values if not self.display_space else srgb_decode(self.values)
        h, w = rgb.shape[:2]
        meta = {"renderer": "image", "path": str(self.path), "encoding": self.encoding, "tonemap": self.tonemap,
                "exposure": self.exposure, "engine": self.engine, "engine_version": self.engine_version}
        mask = np.ones((h, w), bool) if self.coverage is None else self.coverage
        return Render(rgb=np.asarray(rgb, np.float32), mask=mask, timings=dict(self.timings), meta=meta)


def scene_exposure_problem(tonemap: str, exposure: float) -> str | None:
    """What is wrong with an exposure given with `SCENE_TONEMAP` (the scene's transform has its own), or None."""
    if tonemap == SCENE_TONEMAP and exposure != 1.0:
        return (f"exposure {exposure:g} with tone mapping {SCENE_TONEMAP!r}: the scene's display transform has its "
                "own ([tonemap] exposure); leave the image's exposure at 1")
    return None


def check_file(path: str | Path) -> Path:
    """`path` as a Path when it names a regular file; InputError (not found, or a folder) otherwise: checked
    before anything is inferred from its name."""
    path = Path(path)
    if not path.is_file():
        raise InputError(f"{path}: image file not found" if not path.exists() else
                         f"{path}: is a folder, not an image file" if path.is_dir() else f"{path}: not a regular file")
    return path


def timings_path(image: str | Path) -> Path:
    """The timings JSON an engine may write beside its image: FRAME.exr -> FRAME.timings.json."""
    image = Path(image)
    return image.with_name(image.name[: -len(image.suffix)] + TIMINGS_SUFFIX)


def default_encoding(path: Path) -> str | None:
    """The encoding a file's suffix implies: "linear" for EXR/PFM/HDR, None for PNG/JPEG (must be named)."""
    return "linear" if Path(path).suffix.lower() in LINEAR_SUFFIXES else None


def read_engine_image(path: str | Path, scene, encoding: str = "linear", tonemap: str = "none",
                      exposure: float = 1.0, timings: str | Path | None = None) -> EngineImage:
    """Read and check an engine's image of `scene` (module docstring). `timings`: the engine's timings
    JSON; by default FRAME.timings.json beside the image when it exists."""
    path = Path(path)
    suffix = path.suffix.lower()
    if encoding not in ENCODINGS:
        raise InputError(f"{path}: image encoding {encoding!r} is unknown; choose linear or srgb")
    if tonemap not in TONEMAPS:
        raise InputError(f"{path}: tone mapping {tonemap!r} is unknown; choose one of {', '.join(TONEMAPS)}")
    if not (isinstance(exposure, (int, float)) and math.isfinite(exposure) and exposure > 0):
        raise InputError(f"{path}: exposure {exposure!r} must be a finite number > 0")
    if problem := scene_exposure_problem(tonemap, exposure):
        raise InputError(f"{path}: {problem}")
    check_file(path)
    if suffix not in LINEAR_SUFFIXES and suffix not in DISPLAY_SUFFIXES:
        raise InputError(f"{path}: image suffix {suffix or '(none)'!r} is not read: linear radiance as .exr, .pfm "
                         "or .hdr; a tone-mapped sRGB image as .png, .jpg or .jpeg")
    if encoding == "linear":
        if suffix in DISPLAY_SUFFIXES:
            raise InputError(f"{path}: a {suffix} image holds 8- or 16-bit display code values, not linear radiance; "
                             "name its tone mapping with encoding srgb (--image-encoding srgb --tonemap NAME), or "
                             "write the engine's linear radiance as OpenEXR")
        if tonemap != "none" or exposure != 1.0:
            raise InputError(f"{path}: a linear image is radiance, measured with the scene's own display transform; "
                             f"tone mapping {tonemap!r} and exposure {exposure:g} apply to an srgb image only")
        linear = linear_image.read(path)
        values, bits, alpha, coverage = linear.rgb, None, False, linear.coverage
        if coverage is not None and not coverage.any():
            raise InputError(f"{path}: alpha < 0.5 at every pixel; an OpenEXR alpha is the engine's coverage, so no "
                             "pixel would be compared: write alpha 1 where the engine drew, or no alpha channel")
    else:
        if suffix in LINEAR_SUFFIXES:
            raise InputError(f"{path}: a {suffix} file holds linear radiance, not sRGB code values; read it as "
                             "encoding linear")
        values, bits, alpha = _read_display(path)
        coverage = None
    h, w = values.shape[:2]
    if (w, h) != (scene.camera.width, scene.camera.height):
        raise InputError(f"{path}: image of {w} x {h} pixels; the scene {scene.name!r} renders "
                         f"{scene.camera.width} x {scene.camera.height} (camera.width x camera.height)")
    tpath = Path(timings) if timings is not None else timings_path(path)
    reported = engine_timings.EngineTimings() if timings is None and not tpath.is_file() else engine_timings.read(tpath)
    return EngineImage(path, encoding, tonemap, float(exposure), values, bits, reported.as_render_timings(),
                       reported.engine or None, reported.version or None, alpha, coverage)


def _png_bits(path: Path) -> int | None:
    """A PNG's bit depth, None for a file that is not one (a JPEG saved as .png: Pillow reads it)."""
    try:
        return png16.bit_depth(path)
    except InputError:
        return None


def _read_display(path: Path) -> tuple[np.ndarray, int, bool]:
    """Code values in [0, 1], the bit depth, and whether an alpha channel was dropped."""
    if path.suffix.lower() == ".png" and _png_bits(path) == 16:
        raw = png16.read(path)  # Pillow would read a 16-bit RGB(A) PNG as 8 bits a channel
        raw = raw[..., 0] if raw.shape[2] == 1 else raw
    else:
        try:
            raw = iio.imread(path, plugin="pillow")  # named: imageio's fallback plugins warn before they fail
        except Exception as exc:  # imageio/Pillow raise OSError, ValueError, SyntaxError for corrupt files
            raise InputError(f"{path}: not a readable PNG or JPEG image ({type(exc).__name__})") from None
    if raw.dtype == np.uint8:
        bits, top = 8, 255.0
    elif raw.dtype == np.uint16:
        bits, top = 16, 65535.0
    else:
        raise InputError(f"{path}: {raw.dtype} pixels; an sRGB image holds 8- or 16-bit integers")
    alpha = False
    if raw.ndim == 2:  # grey: R = G = B
        raw = np.repeat(raw[..., None], 3, axis=-1)
    elif raw.ndim == 3 and raw.shape[2] in (2, 4):  # grey + alpha, RGBA: the alpha is ignored
        alpha = True
        raw = np.repeat(raw[..., :1], 3, axis=-1) if raw.shape[2] == 2 else raw[..., :3]
    elif not (raw.ndim == 3 and raw.shape[2] == 3):
        raise InputError(f"{path}: image of shape {raw.shape}; expected grey, RGB or RGBA")
    return raw.astype(np.float64) / top, bits, alpha


# --------------------------------------------------------------------------- display-space measurement


def display_reference(rgb: np.ndarray, image: EngineImage, scene) -> np.ndarray:
    """The reference's radiance as the engine's file would hold it: the named operator and exposure (the
    scene's display transform for `SCENE_TONEMAP`), the sRGB encoding, rounded to the image's bit depth, in
    [0, 1]."""
    if image.tonemap == SCENE_TONEMAP:
        encoded = np.asarray(metrics.display(scene, rgb), np.float64)
    else:
        encoded = srgb_encode(tone_operators.apply(image.tonemap, rgb, image.exposure))
    top = float((1 << image.bits) - 1) if image.bits else None
    return encoded if top is None else np.round(encoded * top) / top


def measure_display_pair(image: EngineImage, reference: Render, scene, *,
                         second_reference: Render | None = None) -> Measurement:
    """`measure_pair`'s Measurement for a tone-mapped sRGB image: both sides in the engine's display space
    (module docstring). `rel_mse` and `psnr_unbiased` are None; the noise floor is that of the two
    references in the same display space."""
    a = np.asarray(image.values, np.float64)
    b = display_reference(reference.rgb, image, scene)
    covered = metrics.common_mask(np.ones(a.shape[:2], bool), reference.mask)
    empty = metrics.no_signal(b, covered)
    clipped = clipped_share(scene, b, covered, empty)
    mask = np.zeros_like(covered) if empty else covered
    if second_reference is None:
        b2, noise_mask = None, mask
        floor = metrics.PSNR_CAP if mask.any() else None
    else:
        b2, noise_mask = display_reference(second_reference.rgb, image, scene), mask & second_reference.mask
        floor = metrics.noise_floor_psnr(b, b2, noise_mask)
    ssim = metrics.ssim(a, b, mask, full=True)
    flip_map = metrics.flip_map(a.astype(np.float32), b.astype(np.float32))
    return Measurement(
        test=a.astype(np.float32), reference=b.astype(np.float32),
        reference2=None if b2 is None else b2.astype(np.float32), mask=covered, noise_mask=noise_mask,
        empty=empty, psnr=metrics.psnr(a, b, mask), psnr_unbiased=metrics.UnbiasedPSNR(None, False),
        noise_floor_psnr=floor, ssim=ssim.value, ssim_map=ssim.map, ssim_selection=ssim.selection,
        flip=float(flip_map[mask].mean()) if mask.any() else None, flip_map=flip_map, rel_mse=None, clipped=clipped)


def compare_image(image: EngineImage, scene, reference: Render | None = None,
                  reference2: Render | None = None) -> comparison.Comparison:
    """`comparison.compare_renders` of an engine's image against the scene's (cached) reference: the same
    dict, plus `image`, `engine`, `encoding`, `tonemap` and, in display space, `note` (`DISPLAY_ONLY`)."""
    if reference is None:
        reference = groundtruth.render(scene)
    if reference2 is None:
        reference2 = comparison.second_reference(reference, scene)
    test = image.render()
    if image.display_space:
        m = measure_display_pair(image, reference, scene, second_reference=reference2)
    else:
        m = measure_pair(test, reference, scene, second_reference=reference2)
    result = comparison.compare(test, reference, scene, reference2, measured=m)
    result.update(image_fields(image))
    if image.display_space:
        result.update(psnr_unbiased=None, psnr_unbiased_clamped=None, rel_mse=None)
    return comparison.Comparison(result, test, reference, m)


def image_fields(image: EngineImage) -> dict:
    """What a comparison's dict says about the image: its file, engine, encoding, operator, note."""
    return {"image": str(image.path), "engine": image.engine, "engine_version": image.engine_version,
            "encoding": image.encoding, "tonemap": image.tonemap, "exposure": image.exposure,
            **({"note": DISPLAY_ONLY} if image.display_space else {}),
            **({"alpha": "ignored"} if image.alpha_ignored else {})}
