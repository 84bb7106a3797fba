"""The convention mistakes `iblcheck diagnose` tests, each with its forward model.

A forward model says what an engine's image would be if the engine made the mistake: it is applied to
the reference (never to the engine's image), so that a mistake explains the engine's image when the
reference passed through its model matches that image better than the plain reference does.

| name             | stage    | image   | parameter | forward model, applied to the reference                      |
|------------------|----------|---------|-----------|--------------------------------------------------------------|
| env_rotation     | scene    | both    | angle_deg | re-rendered with environment.rotation_deg + angle (fitted)   |
| env_u_mirror     | scene    | both    |           | re-rendered with the viewer file's u mirrored (z -> -z)      |
| fov_horizontal   | scene    | both    |           | re-rendered with the vertical fov 2 atan(tan(fov/2) H / W)   |
| half_pixel       | render   | both    |           | pixel (i, j): the box over [j - 1/2, j + 1/2] x [i - 1/2, ..]|
| tonemap          | radiance | both    | operator  | linear: tone_operators.apply(operator, rgb) written as       |
|                  |          |         |           | radiance; display: another operator than the named one      |
| srgb_encoded     | radiance | linear  |           | the sRGB encoding on every channel (not clamped above 1)     |
| exposure         | radiance | both    | factor    | rgb x factor (linear: least squares; display: before the     |
|                  |          |         |           | operator, 1-D search, display.py)                            |
| srgb_not_encoded | display  | display |           | display-linear values written as code values                 |
| srgb_twice       | display  | display |           | the sRGB encoding applied twice                              |
| mirror_x         | image    | both    |           | columns reversed                                             |
| mirror_y         | image    | both    |           | rows reversed                                                |

Several mistakes compose in one fixed order: the scene's (a re-render of the changed scene, with the
half-pixel footprint where it is in), then, for a linear image, tonemap, sRGB, exposure, or, for a
display image (display.py), exposure x the named exposure, the operator, the encoding; the flips
commute with everything after the render.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

LINEAR, DISPLAY = "linear", "display"


@dataclass(frozen=True)
class Hypothesis:
    """One mistake: its name, where its forward model acts, its fitted parameter (or None), in words, and
    the kinds of engine image it applies to (LINEAR radiance, DISPLAY: a tone-mapped sRGB PNG or JPEG)."""

    name: str
    stage: str  # "scene" | "render" | "radiance" | "image" | "display"
    parameter: str | None
    meaning: str
    images: tuple[str, ...] = (LINEAR, DISPLAY)


HYPOTHESES = (
    Hypothesis("mirror_x", "image", None, "the image is flipped left-right"),
    Hypothesis("mirror_y", "image", None, "the image is flipped upside down"),
    Hypothesis("env_rotation", "scene", "angle_deg", "the environment is turned about +Y by angle_deg "
               "(right-handed, as environment.rotation_deg)"),
    Hypothesis("env_u_mirror", "scene", None, "the exported environment.hdr is read with u mirrored (the viewer "
               "convention's u -> 1 - u: a lookup at (x, y, -z))"),
    Hypothesis("fov_horizontal", "scene", None, "camera.fov_deg is taken as the horizontal field of view"),
    Hypothesis("srgb_encoded", "radiance", None, "sRGB-encoded values are written as linear radiance", (LINEAR,)),
    Hypothesis("srgb_not_encoded", "display", None, "display-linear values are written without the sRGB "
               "encoding", (DISPLAY,)),
    Hypothesis("srgb_twice", "display", None, "the sRGB encoding is applied twice", (DISPLAY,)),
    Hypothesis("exposure", "radiance", "factor", "the radiance is scaled by a constant factor (before the tone "
               "operator in a display image)"),
    Hypothesis("half_pixel", "render", None, "pixel centres at integers: the image is shifted by half a pixel "
               "up and left"),
    Hypothesis("tonemap", "radiance", "operator", "a tone operator is applied (linear image: display-linear "
               "values are written as radiance; display image: another operator than the named one)"),
)
BY_NAME = {h.name: h for h in HYPOTHESES}
NAMES = tuple(BY_NAME)
#: the mistakes tested on each kind of image
FOR_IMAGE = {kind: tuple(h.name for h in HYPOTHESES if kind in h.images) for kind in (LINEAR, DISPLAY)}
#: the scene-level mistakes: they need a re-render of the reference
SCENE_LEVEL = ("env_rotation", "env_u_mirror", "fov_horizontal")
#: mistakes that cannot both be made (the encoding is left out or applied twice, not both)
EXCLUDES = {"srgb_not_encoded": "srgb_twice", "srgb_twice": "srgb_not_encoded"}


def horizontal_fov_as_vertical(fov_deg: float, width: int, height: int) -> float:
    """The vertical field of view an engine gets when it reads `fov_deg` as the horizontal one.

    With a horizontal fov F the half-width of the image plane at distance 1 is tan(F / 2), its half-height
    tan(F / 2) H / W, so the vertical fov is 2 atan(tan(F / 2) H / W) (gluPerspective's relation).
    """
    return math.degrees(2.0 * math.atan(math.tan(math.radians(fov_deg) / 2.0) * height / width))


def mirror_u(env: np.ndarray) -> np.ndarray:
    """iblcheck's map as an engine that mirrors the u of the exported viewer-convention file sees it.

    An engine mirrors the u of the file it reads: the exported `environment.hdr`, in the viewer
    convention u_v = 0.5 + atan2(d.z, d.x) / (2 pi) (scenes/exchange/viewer_equirect.py). Reading it at
    1 - u_v(d) is reading it at the direction d' with atan2(d'.z, d'.x) = -atan2(d.z, d.x), d' = (d.x,
    d.y, -d.z): a z-mirror. In iblcheck's convention u_i = u_v - 1/4, so u_i(d') = 1 - u_v(d) - 1/4 =
    1/2 - u_i(d): the new map M' has M'(u) = M(1/2 - u). With lookup's col = u W - 1/2, new column c
    (u = (c + 1/2) / W) reads the old map at col (1/2 - u) W - 1/2 = W/2 - 1 - c. For even W that is a
    whole column: M'[:, c] = M[:, (W/2 - 1 - c) mod W], and since the relation is affine in the column
    (a reflection), bilinear weights map onto each other too: a lookup of M' at d equals a lookup of M
    at d' everywhere. (Reversing iblcheck's own columns, u -> 1 - u, is x -> -x: the z-mirror plus a half
    turn.) For odd W the old column is a half-integer: M'[:, c] is the mean of the two columns either
    side, exactly M's lookup at d' on the texel centres, half a texel blurred between them (no map of
    this convention reproduces the mirrored lookup exactly: its sample columns fall halfway).
    """
    env = np.asarray(env)
    w = env.shape[1]
    c = np.arange(w)
    if w % 2 == 0:
        return np.ascontiguousarray(env[:, (w // 2 - 1 - c) % w])
    lo = (w // 2 - 1 - c) % w  # W/2 - 1 - c = (w // 2 - 1 - c) + 1/2
    return 0.5 * (env[:, lo] + env[:, (lo + 1) % w])


def srgb_oetf(rgb: np.ndarray) -> np.ndarray:
    """IEC 61966-2-1's sRGB encoding per channel, not clamped above 1 (as three.js's sRGBTransferOETF).

    x <= 0.0031308: 12.92 x; else 1.055 x^(1/2.4) - 0.055; negative values become 0.
    """
    x = np.maximum(np.asarray(rgb, np.float64), 0.0)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1.0 / 2.4) - 0.055)


def half_pixel_shift(supersampled: np.ndarray) -> np.ndarray:
    """An image whose pixel (i, j) covers [j - 1/2, j + 1/2] x [i - 1/2, i + 1/2], from a 2x supersampled one.

    `supersampled` (2H, 2W, C) is a box-filtered render at twice the resolution: its pixel (a, b) covers
    [b / 2, (b + 1) / 2] x [a / 2, (a + 1) / 2] in the image's pixel units, so the 2 x 2 block of rows
    2i - 1, 2i and columns 2j - 1, 2j covers the shifted pixel exactly: the box average over the shifted
    footprint, no interpolation. Row and column -1 (outside the frame) repeat row and column 0.
    """
    s = np.asarray(supersampled, np.float64)
    padded = np.pad(s, ((1, 0), (1, 0), (0, 0)), mode="edge")[:-1, :-1]  # padded[a] = s[a - 1]
    h, w = padded.shape[0] // 2, padded.shape[1] // 2
    return padded.reshape(h, 2, w, 2, -1).mean(axis=(1, 3))


def block_average(supersampled: np.ndarray) -> np.ndarray:
    """The 1x image of a 2x supersampled box-filtered one (2 x 2 block means): the unshifted footprint."""
    s = np.asarray(supersampled, np.float64)
    h, w = s.shape[0] // 2, s.shape[1] // 2
    return s.reshape(h, 2, w, 2, -1).mean(axis=(1, 3))


def flip(rgb: np.ndarray, mistakes: dict) -> np.ndarray:
    """The image-stage mistakes of `mistakes`: mirror_x reverses the columns, mirror_y the rows."""
    if "mirror_x" in mistakes:
        rgb = rgb[:, ::-1]
    if "mirror_y" in mistakes:
        rgb = rgb[::-1]
    return rgb


def fit_exposure(prediction: np.ndarray, image: np.ndarray, mask: np.ndarray) -> float:
    """The factor k minimising sum over masked pixels and channels of (k P - I)^2: k = <P, I> / <P, P>.

    1 when the prediction is black over the mask (no factor is defined).
    """
    p = np.asarray(prediction, np.float64)[mask]
    i = np.asarray(image, np.float64)[mask]
    pp = float((p * p).sum())
    return float((p * i).sum() / pp) if pp > 0 else 1.0
