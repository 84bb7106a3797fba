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

from dataclasses import dataclass

import numpy as np

from experiments.measure import metrics
from scenes.model.render import Render


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
        `metrics.common_mask` of the test's and the reference's coverage: the pixels of every metric.
    noise_mask : ndarray of bool, shape (H, W)
        `mask` and the second reference's coverage: the pixels of `psnr_unbiased` and the noise floor
        (`mask` itself without a second reference).
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
    mask = metrics.common_mask(test.mask, reference.mask)
    a, b = metrics.display(scene, test.rgb), metrics.display(scene, reference.rgb)
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
        test=a, reference=b, reference2=b2, mask=mask, noise_mask=noise_mask,
        psnr=metrics.psnr(a, b, mask), psnr_unbiased=unbiased, noise_floor_psnr=floor,
        ssim=ssim.value, ssim_map=ssim.map, ssim_selection=ssim.selection,
        flip=float(flip_map[mask].mean()) if mask.any() else None, flip_map=flip_map,
        rel_mse=metrics.rel_mse(test.rgb, reference.rgb, mask))
