"""The GL context's limits are checked before a resource is made, never silently exceeded.

A texture side or a work-group count beyond the context's limit is refused (exit 3) naming the limit
and the scene key; a storage buffer beyond the reported block size gets a warning; an environment map
wider or taller than one texture is downsampled by area with a warning. Small limits are simulated
with a fake `ctx.info` (unit checks) or by substituting `limits.limit` (whole renders); the real
16384 of Mesa llvmpipe is exercised with a 16400-wide map.
"""

from __future__ import annotations

import warnings
from types import SimpleNamespace

import moderngl
import numpy as np
import pytest

import realtime
import scenes
from experiments.cli import main as cli
from realtime.engine import limits, technique
from realtime.engine.context import get_context
from realtime.engine.gpu import compile_shading
from scenes import MissingCapability
from scenes.environment.directions import equirect_solid_angles
from tests.hard.common import write_env, write_tiny

SMALL = {"GL_MAX_TEXTURE_SIZE": 64, "GL_MAX_CUBE_MAP_TEXTURE_SIZE": 32, "GL_MAX_3D_TEXTURE_SIZE": 16,
         "GL_MAX_RENDERBUFFER_SIZE": 64, "GL_MAX_ARRAY_TEXTURE_LAYERS": 4,
         "GL_MAX_SHADER_STORAGE_BLOCK_SIZE": 1024, "GL_MAX_COMPUTE_WORK_GROUP_COUNT": (100, 50, 10)}


def fake(info: dict) -> SimpleNamespace:
    return SimpleNamespace(info=info)


def sphere_integral(env: np.ndarray) -> np.ndarray:
    """The map's integral over the sphere (sum of radiance times texel solid angle), per channel."""
    h, w = env.shape[:2]
    return np.einsum("hwc,hw->c", env.astype(np.float64), equirect_solid_angles(h, w))


# -- the checks, against a fake context ------------------------------------------------------------


class RefusingContext(SimpleNamespace):
    """A context whose program() fails to link with `log`, as a driver does."""

    def program(self, **_):
        raise moderngl.Error(self.log)


def test_too_many_samplers_in_the_shading_pass_is_refused_naming_the_techniques():
    """Mesa's linker refuses a fragment stage with more active samplers than GL_MAX_TEXTURE_IMAGE_UNITS with
    "Too many fragment shader texture samplers": the refusal names the chosen techniques and the limit (exit 3),
    not an internal error. Negative control: any other link error (a syntax error) is raised as it is."""
    vct = technique.declaration_of("occlusion", "vct")
    ctx = RefusingContext(info={"GL_MAX_TEXTURE_IMAGE_UNITS": 16},
                          log="error: linking failed: error: Too many fragment shader texture samplers")
    with pytest.raises(limits.GLLimitExceeded, match=r"^realtime\.occlusion = 'vct': the shading pass samples "
                                                     r"more textures than .* GL_MAX_TEXTURE_IMAGE_UNITS = 16"):
        compile_shading(ctx, [vct], ())
    ctx.log = "0:12(3): error: syntax error, unexpected IDENTIFIER"
    with pytest.raises(moderngl.Error, match="syntax error"):
        compile_shading(ctx, [vct], ())


@pytest.mark.parametrize("kind, size, name", [
    ("2d", (65, 3), "GL_MAX_TEXTURE_SIZE"), ("2d", (3, 65), "GL_MAX_TEXTURE_SIZE"),
    ("cube", (33, 33), "GL_MAX_CUBE_MAP_TEXTURE_SIZE"), ("3d", (8, 8, 17), "GL_MAX_3D_TEXTURE_SIZE"),
    ("3d", (17, 8, 8), "GL_MAX_3D_TEXTURE_SIZE"), ("array", (65, 65, 2), "GL_MAX_TEXTURE_SIZE"),
    ("array", (8, 8, 5), "GL_MAX_ARRAY_TEXTURE_LAYERS"), ("framebuffer", (65, 8), "GL_MAX_RENDERBUFFER_SIZE"),
])
def test_a_texture_beyond_the_limit_is_refused_naming_limit_and_key(kind, size, name):
    with pytest.raises(limits.GLLimitExceeded, match=rf"^some\.key: .* above this OpenGL context's {name} = "):
        limits.check_texture(fake(SMALL), kind, size, "some.key")
    assert issubclass(limits.GLLimitExceeded, MissingCapability)  # the CLI's exit 3


@pytest.mark.parametrize("kind, size", [("2d", (64, 64)), ("cube", (32, 32)), ("3d", (16, 16, 16)),
                                        ("array", (64, 64, 4)), ("framebuffer", (64, 1)), ("2d", (1, 1))])
def test_a_texture_at_the_limit_is_accepted(kind, size):
    limits.check_texture(fake(SMALL), kind, size, "some.key")  # the limit itself is allowed (negative control)


@pytest.mark.parametrize("counts, axis", [((101,), "x"), ((1, 51), "y"), ((1, 1, 11), "z")])
def test_too_many_work_groups_are_refused(counts, axis):
    with pytest.raises(limits.GLLimitExceeded, match=rf"work groups along {axis}.*GL_MAX_COMPUTE_WORK_GROUP_COUNT"):
        limits.check_groups(fake(SMALL), counts, "realtime.lights.count")
    limits.check_groups(fake(SMALL), (100, 50, 10), "realtime.lights.count")  # at the limit: fine


@pytest.mark.parametrize("nbytes, refused", [((1 << 31) - 1, False), (1 << 31, True)])
def test_a_storage_buffer_past_2_gib_is_refused_whatever_the_driver_reports(nbytes, refused):
    """A driver reporting a block size of 4 GiB still gets no buffer past 2^31 - 1 bytes (llvmpipe crashes
    reading one); one byte less passes silently, within the reported size."""
    huge = fake({**SMALL, "GL_MAX_SHADER_STORAGE_BLOCK_SIZE": 1 << 32})
    if refused:
        with pytest.raises(limits.GLLimitExceeded, match=r"realtime\.vct\.resolution: .* 2147483648 bytes"):
            limits.check_storage(huge, nbytes, "realtime.vct.resolution")
    else:
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            limits.check_storage(huge, nbytes, "realtime.vct.resolution")


def test_a_storage_buffer_beyond_the_block_size_warns_and_goes_on():
    with pytest.warns(limits.StorageLimitWarning, match=r"realtime\.vct\.resolution: .* 1025 bytes.*1024"):
        limits.check_storage(fake(SMALL), 1025, "realtime.vct.resolution")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        limits.check_storage(fake(SMALL), 1024, "realtime.vct.resolution")  # at the limit: silent


def test_an_unreported_limit_falls_back_to_what_opengl_43_guarantees():
    with pytest.raises(limits.GLLimitExceeded, match="GL_MAX_TEXTURE_SIZE = 1024"):
        limits.check_texture(fake({}), "2d", (1025, 4), "environment.map")
    limits.check_texture(fake({}), "2d", (1024, 4), "environment.map")


def test_every_limit_iblcheck_checks_is_reported_by_this_context():
    info = get_context().info
    for name in {*limits.TEXTURE_LIMITS.values(), limits.LAYERS_LIMIT, limits.STORAGE_LIMIT, limits.GROUPS_LIMIT}:
        assert name in info, name


# -- a map too large for one texture ----------------------------------------------------------------


@pytest.mark.parametrize("shape, target", [((3, 40), (3, 16)), ((40, 8), (16, 8)), ((41, 37), (16, 16)),
                                           ((5, 100), (5, 7))])
def test_downsampling_keeps_the_maps_integral(shape, target):
    rng = np.random.default_rng(sum(shape))
    env = rng.uniform(0.0, 10.0, (*shape, 3)).astype(np.float32)
    small = limits.downsample_equirect(env, width=target[1], height=target[0])
    assert small.shape == (*target, 3) and small.dtype == np.float32
    np.testing.assert_allclose(sphere_integral(small), sphere_integral(env), rtol=1e-5)
    assert small.min() >= env.min() - 1e-5 and small.max() <= env.max() + 1e-5  # means, never beyond the range


def test_downsampling_whole_blocks_of_columns_is_their_mean():
    env = np.arange(3 * 8 * 3, dtype=np.float32).reshape(3, 8, 3)
    small = limits.downsample_equirect(env, width=2, height=3)
    np.testing.assert_allclose(small, env.reshape(3, 2, 4, 3).mean(axis=2), rtol=1e-6)


def test_a_constant_map_stays_constant():
    env = np.full((50, 90, 3), 0.7, np.float32)
    np.testing.assert_allclose(limits.downsample_equirect(env, 16, 16), 0.7, rtol=1e-6)


def test_fit_equirect_warns_once_and_leaves_a_fitting_map_alone():
    env = np.ones((3, 80, 3), np.float32)
    with pytest.warns(UserWarning, match=r"^env\.key: the map is 80 x 3 texels, beyond .*GL_MAX_TEXTURE_SIZE = 64: "
                                         r"the real-time image reads it downsampled to 64 x 3") as record:
        out = limits.fit_equirect(fake(SMALL), env, "env.key")
    assert len(record) == 1 and out.shape == (3, 64, 3)
    fits = np.ones((64, 64, 3), np.float32)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert limits.fit_equirect(fake(SMALL), fits, "env.key") is fits  # negative control: untouched


# -- whole renders ------------------------------------------------------------------------------------


def two_band_map(width: int, height: int) -> np.ndarray:
    """Upper half of the rows 2.0, lower half 0.5: its downsampled versions agree texel for texel with
    it wherever a new texel does not straddle the middle row."""
    env = np.full((height, width, 3), 0.5, np.float32)
    env[: height // 2] = 2.0
    return env


@pytest.mark.parametrize("width, height", [(16400, 3), (3, 100000), (20000, 4)])
def test_a_map_beyond_the_real_texture_limit_renders_what_the_reference_sees(tmp_path, width, height):
    """Before: an all-black real-time image with exit 0. Now: a warning, and the same image as a map of the
    same content within the limit (16384 on llvmpipe; a map of two bands keeps its content downsampled)."""
    most = get_context().info["GL_MAX_TEXTURE_SIZE"]
    big = write_env(tmp_path / f"big{width}x{height}.exr", two_band_map(width, height))
    fits = write_env(tmp_path / "fits.exr", two_band_map(min(width, 64), 64 if height > 4 else height))
    render = {}
    for label, path in (("big", big), ("fits", fits)):
        scene = scenes.load(write_tiny(tmp_path, env=str(path), name=label))
        with warnings.catch_warnings(record=True) as record:
            warnings.simplefilter("always")
            render[label] = realtime.render(scene)
        said = [str(w.message) for w in record if "GL_MAX_TEXTURE_SIZE" in str(w.message)]
        assert len(said) == (1 if label == "big" and max(width, height) > most else 0), said
    big_r, fits_r = render["big"], render["fits"]
    assert big_r.rgb[big_r.mask].mean() > 0.1 and big_r.rgb[~big_r.mask].mean() > 0.1  # not black
    np.testing.assert_array_equal(big_r.mask, fits_r.mask)
    np.testing.assert_allclose(big_r.rgb[big_r.mask].mean(axis=0), fits_r.rgb[fits_r.mask].mean(axis=0), rtol=0.02)


@pytest.fixture
def small_limits(monkeypatch):
    """The whole engine reads limits through `limits.limit`: a table of small ones in its place."""
    table: dict = {}

    def limit(ctx, name):
        return table[name] if name in table else ctx.info.get(name, limits.GUARANTEED[name])

    monkeypatch.setattr(limits, "limit", limit)
    return table


def test_a_map_beyond_a_small_limit_is_downsampled_and_the_light_array_reads_the_same(tmp_path, small_limits):
    """The light array's texel lists and the uploaded map must have one size: both read the fitted map."""
    small_limits["GL_MAX_TEXTURE_SIZE"] = 200  # >= 6 x base_size 32 (the cube's lookup table)
    env = write_env(tmp_path / "m.exr", two_band_map(400, 3))
    scene = scenes.load(write_tiny(tmp_path, env=str(env))).with_overrides(
        {"realtime.diffuse": "lights", "realtime.glossy": "lights", "realtime.base_size": 32,
         "realtime.face_size": 16, "realtime.lights.count": 12})
    with pytest.warns(UserWarning, match="downsampled to 200 x 3"):
        r = realtime.render(scene)
    power = np.asarray(r.meta["light_array"]["total_power_gpu"])
    np.testing.assert_allclose(power, np.asarray(r.meta["light_array"]["map_integral"]), rtol=1e-4)
    np.testing.assert_allclose(power, sphere_integral(two_band_map(400, 3)), rtol=1e-4)  # the full map's


@pytest.mark.parametrize("table, overrides, words", [
    ({"GL_MAX_CUBE_MAP_TEXTURE_SIZE": 32}, {"realtime.base_size": 64}, "realtime.base_size: the cube map"),
    ({"GL_MAX_TEXTURE_SIZE": 32}, {"realtime.base_size": 64}, "realtime.base_size: the cube map's texel lookup"),
    ({"GL_MAX_TEXTURE_SIZE": 200}, {"realtime.parameterization": "dual_paraboloid", "realtime.base_size": 128},
     "realtime.base_size: the dual_paraboloid map"),
    ({"GL_MAX_ARRAY_TEXTURE_LAYERS": 1}, {"realtime.parameterization": "dual_paraboloid"}, "2 layers"),
    ({"GL_MAX_RENDERBUFFER_SIZE": 15}, {}, "camera.width x camera.height"),
    ({"GL_MAX_3D_TEXTURE_SIZE": 63}, {"realtime.occlusion": "vct", "objects.0.shape": "torus"},
     "realtime.vct.resolution and realtime.vct.cascades"),
    ({"GL_MAX_COMPUTE_WORK_GROUP_COUNT": (10, 65535, 65535)},
     {"realtime.diffuse": "lights", "realtime.glossy": "lights", "realtime.lights.count": 12},
     "realtime.lights.count: the light power sums"),
    ({"GL_MAX_TEXTURE_SIZE": 100}, {"realtime.diffuse": "lights", "realtime.glossy": "lights",
                                    "realtime.occlusion": "shadow_maps", "realtime.lights.count": 4,
                                    "realtime.lights.shadow_map_size": 64, "realtime.base_size": 16,
                                    "realtime.face_size": 16, "objects.0.shape": "torus"},
     "realtime.lights.count = 4 with realtime.lights.shadow_map_size = 64: the shadow atlas"),
    ({"GL_MAX_CUBE_MAP_TEXTURE_SIZE": 16}, {"realtime.diffuse": "irradiance_map", "realtime.base_size": 16,
                                               "realtime.face_size": 16, "realtime.irradiance_map.source_size": 16},
     "realtime.irradiance_map.size: the irradiance cube map"),
    ({"GL_MAX_CUBE_MAP_TEXTURE_SIZE": 16}, {"realtime.glossy": "prefiltered", "realtime.base_size": 32,
                                               "realtime.face_size": 16},
     "realtime.base_size: the cube map"),
])
def test_a_resource_beyond_a_small_limit_exits_3_naming_limit_and_key(tmp_path, capsys, small_limits, table,
                                                                      overrides, words):
    small_limits.update(table)
    scene = write_tiny(tmp_path)
    sets = [a for k, v in overrides.items() for a in ("--set", f"{k}={v}")]
    code = cli.main(["render", str(scene), *sets, "-o", str(tmp_path / "out.exr")])
    err = [line for line in capsys.readouterr().err.splitlines() if not line.startswith("warning:")]
    assert code == 3, err
    assert len(err) == 1 and err[0].startswith("error: ") and words in err[0], err
    assert f"above this OpenGL context's {next(iter(table))}" in err[0]
    assert not (tmp_path / "out.exr").exists()


class ErrorFlags:
    """A context whose glGetError returns the given flags, then GL_NO_ERROR."""

    def __init__(self, *flags: str) -> None:
        self.flags = list(flags)

    @property
    def error(self) -> str:
        return self.flags.pop(0) if self.flags else "GL_NO_ERROR"


@pytest.mark.parametrize("flags", [("GL_OUT_OF_MEMORY",), ("GL_INVALID_VALUE",),
                                   ("GL_INVALID_OPERATION", "GL_OUT_OF_MEMORY")])
def test_a_resource_the_driver_did_not_make_is_refused(flags):
    ctx = ErrorFlags(*flags)
    with pytest.raises(limits.GLLimitExceeded, match=r"^realtime\.base_size: the OpenGL driver did not make the "
                                                     r"cube map \((GL_OUT_OF_MEMORY|GL_INVALID_VALUE)\)"):
        limits.check_created(ctx, "realtime.base_size", "the cube map")
    assert ctx.flags == []  # every flag read: the next check starts clean


@pytest.mark.parametrize("flags", [(), ("GL_INVALID_OPERATION",), ("GL_INVALID_ENUM", "GL_INVALID_OPERATION")])
def test_other_error_flags_are_not_a_refusal(flags):
    """Negative control: flags that do not mean "not made" (a collected object's release) pass, and are cleared."""
    ctx = ErrorFlags(*flags)
    limits.check_created(ctx, "realtime.base_size", "the cube map")
    assert ctx.flags == []


def test_a_cube_map_the_driver_cannot_make_exits_3_not_black(tmp_path, capsys):
    """Within every queried limit (16384) yet beyond llvmpipe's 1 GiB per texture: a 4096-texel RGBA32F cube
    map with its chain is GL_OUT_OF_MEMORY. Before: a black object and exit 0. A driver that makes it passes."""
    if "llvmpipe" not in get_context().info["GL_RENDERER"].lower():
        pytest.skip("the 1 GiB texture limit is llvmpipe's")
    code = cli.main(["render", str(write_tiny(tmp_path)), "--set", "realtime.base_size=4096",
                     "-o", str(tmp_path / "out.exr")])
    err = [line for line in capsys.readouterr().err.splitlines() if not line.startswith("warning:")]
    assert code == 3 and len(err) == 1, err
    assert "realtime.base_size: the OpenGL driver did not make the 4096-texel cube map" in err[0]
    assert "GL_OUT_OF_MEMORY" in err[0]


def test_the_same_scenes_render_under_the_real_limits(tmp_path, capsys):
    """Negative control of the refusals above: on the real context the tiny scene renders (exit 0)."""
    code = cli.main(["render", str(write_tiny(tmp_path)), "--set", "realtime.base_size=64",
                     "-o", str(tmp_path / "out.exr")])
    assert code == 0, capsys.readouterr().err
    assert (tmp_path / "out.exr").exists()
