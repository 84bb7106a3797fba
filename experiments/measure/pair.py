"""One image pair measured once: the display transform, the common mask and every metric with its map.

    measure_pair(test, reference, scene, second_reference=None) -> Measurement

`iblcheck compare`, the gate and every result row (a sweep's and the paper suite's) measure through
`measure_pair`, so that each expensive step runs once per pair: the tone mapping of each image, FLIP
(its map gives the mean and the row's FLIP picture), SSIM (its map gives the mean and the gate's noise
estimates). The row keeps the images and maps its pictures and figures need
(experiments/publish/images.py). The metrics themselves are the plain functions of
experiments/measure/metrics.py; this module only decides which of them run on which images and keeps
what they produced.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

from experiments.measure import metrics
from groundtruth.pathtracer import mitsuba_scene
from scenes.model.render import Render


class MissingEffects(UserWarning):
    """The compared images leave out an effect the scene calls for (`effects_compared`)."""


def reference_unsimulated(reference: Render, scene) -> list[str]:
    """The effects the scene calls for that `reference` leaves out, from its meta: Mitsuba's with the
    direct integrator has no interreflection (groundtruth.pathtracer.mitsuba_scene.unsimulated_effects);
    the quadrature is unoccluded (no occlusion, no interreflection)."""
    renderer = reference.meta.get("renderer")
    if renderer == "reference":
        return mitsuba_scene.unsimulated_effects(scene, reference.meta.get("integrator"))
    if renderer == "quadrature" and not reference.meta.get("occlusion", True):
        return sorted({"occlusion", "interreflection"} & scene.effects)
    return []


def effects_compared(test: Render, reference: Render, scene) -> list[str]:
    """What the two images miss of the scene's effects, in words, one sentence per case: an effect only
    the real-time image lacks is in its error; one both lack is not measured at all; one only the
    reference lacks puts the real-time image's correct effect into the error. The real-time side's
    list (its meta's `unsimulated_effects`) names lobes ("glossy occlusion"), which count as the
    effect ("occlusion") when the reference lacks that effect."""
    test_missing = list(test.meta.get("unsimulated_effects") or [])
    ref_missing = set(reference_unsimulated(reference, scene))
    both = [e for e in test_missing if e.split()[-1] in ref_missing]
    only_test = [e for e in test_missing if e not in both]
    only_ref = sorted(ref_missing - {e.split()[-1] for e in test_missing})
    renderer, integrator = reference.meta.get("renderer"), reference.meta.get("integrator")
    kind = ("the quadrature (unoccluded)" if renderer == "quadrature"
            else f"the reference ({integrator} integrator)" if integrator else "the reference")
    out = []
    if only_test:
        out.append(f"the real-time image lacks {', '.join(only_test)}, which {kind} simulates; its error includes "
                   "the missing effect")
    if both:
        out.append(f"neither image simulates {', '.join(both)} ({kind} leaves it out too); the comparison does not "
                   "measure it")
    if only_ref:
        out.append(f"{kind} lacks {', '.join(only_ref)}, which the real-time image simulates; the error includes "
                   "that effect")
    return out


class EmptyComparison(UserWarning):
    """A comparison whose pixels carry no signal (`metrics.no_signal`): its metrics are None."""


class ClippedComparison(UserWarning):
    """A comparison most of whose pixels display as white in the reference (`metrics.white_share` above
    `CLIPPED_SHARE`): its metrics stand, but an error above the tone mapping's white point does not count there."""


#: the share of a comparison's pixels clipped white in the reference above which a `ClippedComparison` warns and
#: the gate fails: more than half of what the metrics average shows no error for a test image too bright there
#: and dilutes the error of the rest (the builtin scenes at 64 x 64 clip at most 8 %, torus-phong's and
#: rook-phong's highlights)
CLIPPED_SHARE = 0.5


def clipped_words(share: float) -> str:
    """The reason a comparison `share` of whose pixels are clipped white says little (warning and gate failure)."""
    return (f"{share:.0%} of the compared pixels display as white in the reference (clipped by the tone mapping): "
            f"an error there does not count, and their zero errors dilute the rest's; lower tonemap.exposure "
            f"until most of the object is below white")


def clipped_share(scene, reference: np.ndarray, covered: np.ndarray, empty: str | None) -> float | None:
    """`metrics.white_share` of a comparison's reference (display values) over `covered`, None for an empty
    comparison; a `ClippedComparison` warning where it passes `CLIPPED_SHARE`. Both display spaces measure it so
    (`measure_pair`, engine_image.measure_display_pair)."""
    share = None if empty else metrics.white_share(reference, covered)
    if share is not None and share > CLIPPED_SHARE:
        warnings.warn(f"{scene.name}: {clipped_words(share)}", ClippedComparison, stacklevel=3)
    return share


@dataclass(frozen=True)
class Measurement:
    """What `measure_pair` computed for one (test, reference) pair.

    Attributes
    ----------
    test, reference : ndarray, shape (H, W, 3), float32
        The two images in display values (`metrics.display`: the scene's tone mapping, then sRGB).
    reference2 : ndarray, shape (H, W, 3), float32, or None
        The second reference (another seed) in display values; None for a noise-free reference.
    mask : ndarray of bool, shape (H, W)
        `metrics.common_mask` of the test's and the reference's coverage: the pixels of every metric
        (`pixels` counts them), except in an empty comparison (`empty`), whose metrics count none.
    noise_mask : ndarray of bool, shape (H, W)
        `mask` and the second reference's coverage: the pixels of `psnr_unbiased` and the noise floor
        (`mask` itself without a second reference; empty for an empty comparison).
    psnr, ssim, flip, rel_mse : float or None
        The metrics over `mask` (`rel_mse` of linear radiance); None for an empty mask.
    psnr_unbiased : metrics.UnbiasedPSNR
        PSNR against the noise-free truth, estimated with the second reference over `noise_mask`
        (without one, the reference counts as noise-free: `psnr` up to the resolution floor).
    noise_floor_psnr : float or None
        `metrics.noise_floor_psnr` of the two references over `noise_mask`; `metrics.PSNR_CAP` for a
        noise-free reference; None for an empty mask.
    ssim_map : ndarray, shape (H, W), or None
        The channel-mean SSIM map of the whole image (None where `metrics.ssim` computes none).
    ssim_selection : ndarray of bool, shape (H, W), or None
        The pixels `ssim` averages: `mask` without scikit-image's 3-pixel border.
    flip_map : ndarray, shape (H, W)
        The LDR FLIP map of the whole image (`metrics.flip_map`); `flip` is its mean over `mask`.
    empty : str or None
        Why the comparison carries no signal (`metrics.no_signal`: too few covered pixels, no lit pixel
        in the reference, every pixel of the reference clipped white), or None. A comparison with signal
        but more than `CLIPPED_SHARE` of its pixels clipped white keeps its metrics with a
        `ClippedComparison` warning. An empty comparison's metrics are all None, an `EmptyComparison`
        warning says why (printed as a `warning:` line), and the gate fails it unless the scene's
        [gate] table says `allow_empty = true` (experiments/runs/gate.py).
    clipped : float or None
        The share of `mask`'s pixels that display as white in the reference (`metrics.white_share`); None for an
        empty comparison. Above `CLIPPED_SHARE` a `ClippedComparison` warning says so and the gate fails it.
    """

    test: np.ndarray
    reference: np.ndarray
    reference2: np.ndarray | None
    mask: np.ndarray
    noise_mask: np.ndarray
    psnr: float | None
    psnr_unbiased: metrics.UnbiasedPSNR
    noise_floor_psnr: float | None
    ssim: float | None
    ssim_map: np.ndarray | None
    ssim_selection: np.ndarray | None
    flip: float | None
    flip_map: np.ndarray
    rel_mse: float | None
    empty: str | None = None
    clipped: float | None = None

    @property
    def pixels(self) -> int:
        """The number of pixels the metrics count (`mask`)."""
        return int(self.mask.sum())

    @property
    def error_map(self) -> np.ndarray:
        """|test - reference| of the display values, mean over RGB, (H, W): the row's error picture."""
        return np.abs(self.test - self.reference).mean(axis=-1)


def measure_pair(test: Render, reference: Render, scene, *, second_reference: Render | None = None) -> Measurement:
    """Measure `test` against `reference`, every step once (see `Measurement`).

    Parameters
    ----------
    test : Render
        The image under test (the real-time render), linear radiance and coverage.
    reference : Render
        The reference (Mitsuba or the quadrature) of the same scene and camera.
    scene : Scene
        Gives the display transform (`scene.tonemap`, the environment's adaptation luminance): the same
        for every image of the scene.
    second_reference : Render, optional
        The reference rendered with another seed (`groundtruth.pathtracer.reference.second_seed`): its
        independent noise gives `noise_floor_psnr` and `psnr_unbiased`. None: the reference is taken as
        noise-free (floor `metrics.PSNR_CAP`, `psnr_unbiased` is `psnr` up to its resolution floor).

    Returns
    -------
    Measurement
        The display images, the masks, the metrics and the SSIM and FLIP maps.

    Notes
    -----
    Every number equals the metric function called directly on the same images:
    ``metrics.psnr(display(test), display(reference), mask)`` and so on, with
    ``mask = metrics.common_mask(test.mask, reference.mask)``. The FLIP map is computed whatever the
    mask (the row's picture shows it); `flip` is None for an empty mask.
    """
    for line in effects_compared(test, reference, scene):
        warnings.warn(f"{scene.name}: {line}", MissingEffects, stacklevel=2)
    covered = metrics.common_mask(test.mask, reference.mask)
    a, b = metrics.display(scene, test.rgb), metrics.display(scene, reference.rgb)
    empty = metrics.no_signal(b, covered)
    if empty:
        # user text in the message: the CLI prints every warning through text.one_line
        warnings.warn(f"{scene.name}: the compared pixels carry no signal: {empty}; its metrics are null",
                      EmptyComparison, stacklevel=2)
    clipped = clipped_share(scene, b, covered, empty)
    # an empty comparison measures over no pixel, so every metric is None (metrics' convention)
    mask = np.zeros_like(covered) if empty else covered
    if second_reference is None:
        b2, noise_mask = None, mask
        floor = metrics.PSNR_CAP if mask.any() else None
        unbiased = metrics.psnr_unbiased(a, b, b, mask)
    else:
        b2, noise_mask = metrics.display(scene, second_reference.rgb), mask & second_reference.mask
        floor = metrics.noise_floor_psnr(b, b2, noise_mask)
        unbiased = metrics.psnr_unbiased(a, b, b2, noise_mask)
    ssim = metrics.ssim(a, b, mask, full=True)
    flip_map = metrics.flip_map(a, b)
    return Measurement(
        test=a, reference=b, reference2=b2, mask=covered, noise_mask=noise_mask, empty=empty,
        psnr=metrics.psnr(a, b, mask), psnr_unbiased=unbiased, noise_floor_psnr=floor,
        ssim=ssim.value, ssim_map=ssim.map, ssim_selection=ssim.selection,
        flip=float(flip_map[mask].mean()) if mask.any() else None, flip_map=flip_map,
        rel_mse=metrics.rel_mse(test.rgb, reference.rgb, mask), clipped=clipped)
