"""An engine's linear image file (engines/linear_image.py): its format told by its first bytes, its alpha as
coverage, and every fault refused naming the file. The one reader serves the command route and
`compare --image`, so an engine's EXR counts the same pixels by both."""

from __future__ import annotations

import numpy as np
import OpenEXR
import pytest

from engines import linear_image
from experiments.cli.main import main
from scenes import InputError
from scenes.storage import imageio

RGB = np.random.default_rng(3).uniform(0.0, 2.0, (6, 8, 3)).astype(np.float32)


def _exr_with_alpha(path, alpha):
    channels = {c: np.ascontiguousarray(RGB[..., i]) for i, c in enumerate("RGB")}
    channels["A"] = np.ascontiguousarray(alpha, dtype=np.float32)
    with OpenEXR.File({"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}, channels) as f:
        f.write(str(path))


@pytest.mark.parametrize("writer, name, kind", [(imageio.write_exr, "a.exr", "OpenEXR"),
                                                (imageio.write_pfm, "b.exr", "PFM"),  # the name says EXR
                                                (imageio.write_pfm, "c.pfm", "PFM")])
def test_the_format_is_told_by_the_first_bytes(tmp_path, writer, name, kind):
    writer(tmp_path / name, RGB)
    image = linear_image.read(tmp_path / name)
    assert image.format == kind and np.array_equal(image.rgb, RGB) and image.coverage is None


def test_alpha_is_coverage_at_one_half(tmp_path):
    alpha = np.zeros((6, 8), np.float32)
    alpha[:, :3], alpha[:, 3] = 1.0, 0.5  # 0.5 counts as covered, as iblcheck's coverage rule says
    alpha[:, 4] = 0.49
    _exr_with_alpha(tmp_path / "a.exr", alpha)
    coverage = linear_image.read(tmp_path / "a.exr").coverage
    assert coverage[:, :4].all() and not coverage[:, 4:].any()


@pytest.mark.parametrize("fault, words", [("nan_alpha", "alpha channel"), ("nan", "NaN or Inf"),
                                          ("negative", "negative radiance"), ("png", "neither OpenEXR")])
def test_faults_are_refused_naming_the_file(tmp_path, fault, words):
    path = tmp_path / "x.exr"
    if fault == "nan_alpha":
        _exr_with_alpha(path, np.full((6, 8), np.nan, np.float32))
    elif fault == "png":
        path.write_bytes(b"\x89PNG\r\n\x1a\n" + bytes(64))
    else:
        bad = RGB.copy()
        bad[2, 5, 1] = np.nan if fault == "nan" else -1.0
        imageio.write_exr(path, bad)
    with pytest.raises(InputError, match=str(path)) as info:
        linear_image.read(path)
    assert words in str(info.value)


@pytest.mark.parametrize("flag, value", [("--tonemap", "none"), ("--image-encoding", "srgb"), ("--exposure", "2")])
def test_compare_refuses_image_options_without_an_image(capsys, flag, value):
    assert main(["compare", "builtin:sphere-diffuse", flag, value]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith(f"error: {flag}") and "--image FILE" in err and len(err.splitlines()) == 1
