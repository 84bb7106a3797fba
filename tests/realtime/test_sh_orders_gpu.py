"""SH of orders 3 and 4 on the GPU (ShProjector, sh_basis.glsl) against the numpy reference."""

from __future__ import annotations

import numpy as np
import pytest

from realtime.engine import sh
from realtime.engine.context import get_context
from realtime.engine.gpu import EnvironmentFilter, groups, shader_text
from realtime.engine.levels import level_of
from realtime.engine.sh_orders import ShProjector, irradiance_weights
from realtime.techniques.sh import deringing
from scenes.environment import environments
from scenes.environment.shbasis import count, glsl_defines, sh_basis

pytestmark = pytest.mark.gl

BASE = 64
# A compute shader standing in for the shading pass: the contract of sh_orders' module docstring
# (include sh_basis.glsl, bind ShProjector.buffer at 2, E = sum_k weighted[k] y[k]).
EVAL_BODY = """
layout(local_size_x = 64) in;
layout(std430, binding = 2) readonly buffer SH { vec4 coeffs[SH_COUNT]; vec4 weighted[SH_COUNT]; };
layout(std430, binding = 3) readonly buffer Dirs { vec4 dirs[]; };
layout(std430, binding = 4) writeonly buffer Irradiance { vec4 irradiance[]; };
layout(std430, binding = 5) writeonly buffer Basis { float basis[]; };
uniform int n;
void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= uint(n)) return;
    float y[SH_COUNT];
    sh_eval(dirs[i].xyz, y);
    vec3 E = vec3(0.0);
    for (int k = 0; k < SH_COUNT; ++k) {
        E += weighted[k].rgb * y[k];
        basis[i * uint(SH_COUNT) + uint(k)] = y[k];
    }
    irradiance[i] = vec4(E, 0.0);
}
"""


def evaluate_on_gpu(ctx, projector: ShProjector, directions: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(E (N, 3), basis (N, n)) at `directions` from the projector's buffer, through sh_eval."""
    order = projector.order
    src = ("#version 430\n" + "".join(f"#define {d}\n" for d in glsl_defines(order))
           + shader_text("sh_basis.glsl") + EVAL_BODY)
    prog = ctx.compute_shader(src)
    n = len(directions)
    dirs = np.zeros((n, 4), dtype="f4")
    dirs[:, :3] = directions
    bufs = [ctx.buffer(dirs.tobytes()), ctx.buffer(reserve=n * 16), ctx.buffer(reserve=n * count(order) * 4)]
    projector.buffer.bind_to_storage_buffer(2)
    for binding, buf in zip((3, 4, 5), bufs, strict=True):
        buf.bind_to_storage_buffer(binding)
    prog["n"] = n
    prog.run(groups(n, 64))
    ctx.memory_barrier()
    e = np.frombuffer(bufs[1].read(), dtype="f4").reshape(n, 4)[:, :3].astype(np.float64)
    y = np.frombuffer(bufs[2].read(), dtype="f4").reshape(n, count(order)).astype(np.float64)
    for obj in [prog, *bufs]:
        obj.release()
    return e, y


def random_directions(n: int, seed: int = 0) -> np.ndarray:
    d = np.random.default_rng(seed).normal(size=(n, 3))
    return d / np.linalg.norm(d, axis=1, keepdims=True)


@pytest.fixture(scope="module")
def studio():
    f = EnvironmentFilter(get_context(), environments.builtin("studio"), BASE)
    f.fill_base(10.0)
    f.build_chain()
    yield f
    f.release()


@pytest.fixture(scope="module")
def projectors():
    ctx = get_context()
    out = {order: ShProjector(ctx, order) for order in (2, 3, 4)}
    yield out
    for p in out.values():
        p.release()


@pytest.mark.parametrize("order", [3, 4])
@pytest.mark.parametrize("face_size", [1, 2, 8, 64])
@pytest.mark.parametrize("window", ["none", "hanning"])
def test_gpu_projection_matches_numpy(studio, projectors, order, face_size, window):
    level = level_of(face_size, BASE)
    sigma = np.ones(order + 1) if window == "none" else deringing.window("hanning", 3.5, order)
    p = projectors[order]
    p.run(studio.cube, level, face_size, sigma)
    coeffs, weighted = p.read()
    ref = sh.project_cube(studio.read_level(level), order)
    scale = np.abs(ref).max()
    # float32 sums of up to 6 x 64^2 texels: ~1e-7 of the scale in practice, 1e-4 asked
    np.testing.assert_allclose(coeffs, deringing.apply(ref, sigma), atol=1e-4 * scale)
    np.testing.assert_allclose(weighted, irradiance_weights(ref, order, sigma), atol=1e-4 * np.pi * scale)


def test_order_2_projector_matches_the_papers_path(studio, projectors):
    # the same sums as sh_project.comp / sh_reduce.comp: equal to float32 rounding (read_sh is windowed)
    sigma = (1.0, 0.8, 0.5)
    studio.project_sh(16, sigma)
    paper, _ = studio.read_sh()
    projectors[2].run(studio.cube, level_of(16, BASE), 16, sigma)
    coeffs, weighted = projectors[2].read()
    np.testing.assert_allclose(coeffs, paper, atol=1e-6 * np.abs(paper).max())
    np.testing.assert_allclose(weighted, irradiance_weights(paper, 2), atol=1e-6 * np.abs(paper).max() * np.pi)


@pytest.mark.parametrize("order", [2, 3, 4])
def test_sh_eval_is_the_numpy_basis(projectors, order):
    d = random_directions(1000)
    _, y = evaluate_on_gpu(get_context(), projectors[order], d)
    # float32 evaluation of polynomials with |Y| < 1.5: a few ulp
    np.testing.assert_allclose(y, sh_basis(d, order), atol=2e-6)


@pytest.mark.parametrize("order", [2, 3, 4])
def test_gpu_irradiance_matches_numpy(studio, projectors, order):
    p = projectors[order]
    p.run(studio.cube, level_of(32, BASE), 32)
    d = random_directions(500, seed=1)
    e, _ = evaluate_on_gpu(get_context(), p, d)
    ref = sh.irradiance_from_sh(sh.project_cube(studio.read_level(level_of(32, BASE)), order), d)
    np.testing.assert_allclose(e, ref, atol=1e-4 * np.abs(ref).max())


def test_order_3_gives_the_irradiance_of_order_2(studio, projectors):
    # A_3 = 0: band 3's weights are exactly zero, and bands 0-2 are the same float32 sums
    d = random_directions(500, seed=2)
    e = {}
    for order in (2, 3):
        projectors[order].run(studio.cube, level_of(64, BASE), 64)
        e[order], _ = evaluate_on_gpu(get_context(), projectors[order], d)
    _, weighted3 = projectors[3].read()
    assert np.all(weighted3[9:] == 0.0)
    np.testing.assert_allclose(e[3], e[2], atol=1e-6 * np.abs(e[2]).max())


@pytest.mark.parametrize("order", [2, 3, 4])
def test_constant_environment_gives_pi(projectors, order):
    f = EnvironmentFilter(get_context(), environments.builtin("constant"), BASE)
    f.fill_base(0.0)
    projectors[order].run(f.cube, 0, BASE)
    e, _ = evaluate_on_gpu(get_context(), projectors[order], random_directions(200, seed=3))
    f.release()
    # order 4: the cube-invariant band-4 quadrature residue (~1.5e-5 at s = 64, see test_sh_orders)
    np.testing.assert_allclose(e, np.pi, rtol=5e-5)


def test_run_checks_its_arguments(studio, projectors):
    with pytest.raises(ValueError):
        projectors[4].run(studio.cube, 1, 64)
    with pytest.raises(ValueError):
        projectors[4].run(studio.cube, 0, 64, (1.0, 1.0, 1.0))
    with pytest.raises(ValueError):
        ShProjector(get_context(), 9)
