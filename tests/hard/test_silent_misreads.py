"""Silent misreads are refused.

A file that holds no colour radiance is an error naming what it holds (alpha only, depth, chroma, several
layers or parts, integers, a crop); a PFM scale of 0 is no byte order; a folder, device, pipe or link loop
given as a map says so; error lines never carry Python's own words and stay short; meshes have a stated
face limit, checked before parsing, and the convexity test no longer costs O(V F).
"""

from __future__ import annotations

import struct
import warnings

import numpy as np
import pytest

from experiments.cli import main as cli
from experiments.paper import e06_hostile_cases as hostile
from experiments.paper.e06_hostile_runs import tiny_scene
from scenes import EnvMapError, MeshError, SceneError
from scenes.environment import envmap
from scenes.geometry import meshes
from scenes.storage import imageio
from tests.hard.common import write_env


@pytest.fixture(scope="module")
def maps(tmp_path_factory):
    return hostile.misread_maps(tmp_path_factory.mktemp("maps"))


@pytest.mark.parametrize("index", range(14), ids=lambda i: f"map{i}")
def test_files_without_colour_radiance_are_refused_naming_what_they_hold(maps, index):
    label, path, word = maps[index]
    with pytest.raises(EnvMapError) as err:
        envmap.read(path)
    message = str(err.value)
    assert message.startswith(str(path)) and word in message, (label, message)
    assert not hostile.python_text(message)


def test_every_misread_map_is_refused_through_the_cli_too(maps, tmp_path, capsys):
    for label, path, word in maps:
        code = cli.main(["render", str(tiny_scene(tmp_path, "m", env=str(path)))])
        err = capsys.readouterr().err.strip().splitlines()
        assert code == 2 and len(err) == 1 and word in err[0], (label, err)


@pytest.mark.parametrize(("channels", "want"), [
    ({"Y": 0.25}, 0.25),
    ({"R": 0.1, "G": 0.2, "B": 0.3, "A": 1.0}, (0.1, 0.2, 0.3)),
    ({"diffuse.R": 0.1, "diffuse.G": 0.2, "diffuse.B": 0.3, "diffuse.A": 1.0}, (0.1, 0.2, 0.3)),
    ({"R": 0.1, "G": 0.2, "B": 0.3, "spec.R": 9.0, "spec.G": 9.0, "spec.B": 9.0}, (0.1, 0.2, 0.3)),  # default layer
    ({"R": 0.1, "G": 0.2, "B": 0.3, "Z": 5.0}, (0.1, 0.2, 0.3)),
])
def test_files_with_colour_radiance_still_read(tmp_path, channels, want):
    import OpenEXR

    planes = {k: np.full((4, 8), v, np.float32) for k, v in channels.items()}
    with OpenEXR.File({"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}, planes) as f:
        f.write(str(tmp_path / "ok.exr"))
    np.testing.assert_allclose(envmap.read(tmp_path / "ok.exr")[0, 0], np.broadcast_to(want, 3), rtol=1e-6)


def test_half_float_rgb_still_reads(tmp_path):
    import OpenEXR

    planes = {c: np.full((4, 8), 0.5, np.float16) for c in "RGB"}
    with OpenEXR.File({"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}, planes) as f:
        f.write(str(tmp_path / "h.exr"))
    assert (envmap.read(tmp_path / "h.exr") == 0.5).all()


@pytest.mark.parametrize("header", [b"PF 3 2 -1.0\n", b"PF\n3 2\n-1.0\n", b"PF\n3\n2\n-1\n", b"PF\t3  2\r-1.0\n",
                                    b"PF\n3 2\n-1.0 "])
def test_pfm_headers_in_any_whitespace_read_the_same(tmp_path, header):
    """A header on one line used to move the pixel data by a line's worth of bytes (a silent misread)."""
    pixels = np.arange(18, dtype="<f4").reshape(2, 3, 3)
    (tmp_path / "a.pfm").write_bytes(header + pixels[::-1].tobytes())
    np.testing.assert_array_equal(imageio.read_pfm(tmp_path / "a.pfm"), pixels)


@pytest.mark.parametrize("scale", [b"0", b"0.0", b"-0", b"+0.000", b"nan", b"inf", b"-inf", b"1e999"])
def test_pfm_scale_without_a_byte_order_is_refused(tmp_path, scale):
    body = struct.pack("<12f", *range(12))
    (tmp_path / "z.pfm").write_bytes(b"PF\n2 2\n" + scale + b"\n" + body)
    with pytest.raises(EnvMapError, match="scale"):
        imageio.read_pfm(tmp_path / "z.pfm")


@pytest.mark.parametrize("suffix", [".exr", ".hdr", ".pfm", ".obj", ".toml"])
def test_special_paths_say_what_they_are(tmp_path, suffix):
    (tmp_path / "s").mkdir()
    for label, path, word in hostile.special_paths(tmp_path / "s", suffix):
        if suffix == ".obj":
            load = meshes.load_file
        elif suffix == ".toml":
            import scenes

            load = scenes.load
        else:
            load = envmap.read
        with pytest.raises((EnvMapError, MeshError, SceneError)) as err:
            load(path)
        assert word in str(err.value) and str(path) in str(err.value), (label, str(err.value))


def test_special_paths_in_a_scene_name_the_key(tmp_path, capsys):
    (tmp_path / "s").mkdir()
    for label, path, word in hostile.special_paths(tmp_path / "s"):
        code = cli.main(["render", str(tiny_scene(tmp_path, "s", env=str(path)))])
        line = capsys.readouterr().err.strip()
        assert code == 2 and "environment.map" in line and word in line, (label, line)


# --------------------------------------------------------------------------- error lines


CASES = hostile.mesh_cases()


@pytest.mark.parametrize("index", range(len(CASES)), ids=lambda i: f"mesh{i}")
def test_broken_meshes_are_refused_in_iblcheck_words(tmp_path, index):
    label, kind, data = CASES[index]
    path = tmp_path / f"m.{kind}"
    path.write_bytes(data)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", meshes.MeshWarning)
        outcome = hostile.mesh_outcome(path)
    if label.startswith(("obj cut", "ply cut")):
        assert outcome in ("refused", "loaded"), (label, outcome)
    else:
        assert outcome == "refused", (label, outcome)


@pytest.mark.parametrize(("suffix", "make"), [
    (".hdr", lambda p: imageio.write_hdr(p, np.full((8, 16, 3), 0.5, np.float32))),
    (".pfm", lambda p: imageio.write_pfm(p, np.full((8, 16, 3), 0.5, np.float32))),
    (".exr", lambda p: imageio.write_exr(p, np.full((8, 16, 3), 0.5, np.float32))),
])
def test_truncated_maps_are_refused_in_iblcheck_words(tmp_path, suffix, make):
    good = tmp_path / f"good{suffix}"
    make(good)
    for cut in hostile.truncations(good.read_bytes(), 32):
        path = tmp_path / f"cut{suffix}"
        path.write_bytes(cut)
        try:
            envmap.read(path)
        except EnvMapError as exc:
            assert str(exc).startswith(str(path)) and not hostile.python_text(str(exc)), str(exc)


@pytest.mark.parametrize(("key", "value"), [
    ("objects.0.material.kd", "[" + "0.5," * 1_000_000 + "0.5]"),
    ("camera.origin", "[" + "1," * 200_000 + "1]"),
    ("name", "[" + "'x'," * 100_000 + "'x']"),
    ("environment.map", "'" + "a" * 200_000 + ".exr'"),
    ("realtime.glossy", "'" + "x" * 100_000 + "'"),
    ("objects.0.shape", "'" + "m" * 5000 + ".obj'"),
])
def test_error_lines_stay_short_and_name_the_key(tmp_path, capsys, key, value):
    code = cli.main(["render", str(tiny_scene(tmp_path)), "--set", f"{key}={value}"])
    line = capsys.readouterr().err.strip()
    assert code == 2 and "\n" not in line and len(line) < 1000, len(line)
    assert key.replace("objects.0", "objects[0]") in line or key in line, line[:300]
    assert not hostile.python_text(line)


# --------------------------------------------------------------------------- mesh sizes


def test_the_face_limit_is_checked_before_parsing(tmp_path, monkeypatch):
    monkeypatch.setattr(meshes, "MAX_TRIANGLES", 100)
    (tmp_path / "a.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\n" + "f 1 2 3\n" * 101)
    with pytest.raises(MeshError, match="101 triangles, more than the limit of 100"):
        meshes.load_file(tmp_path / "a.obj")
    (tmp_path / "q.obj").write_text("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n" + "f 1 2 3 4\n" * 60)  # 120 triangles
    with pytest.raises(MeshError, match="120 triangles"):
        meshes.load_file(tmp_path / "q.obj")
    head = hostile.good_ply(True).replace(b"element face 2", b"element face 1000000000")
    (tmp_path / "a.ply").write_bytes(head)  # a billion faces claimed: refused from the header, nothing read
    with pytest.raises(MeshError, match="1000000000 triangles"):
        meshes.load_file(tmp_path / "a.ply")


def test_builtin_resolutions_over_the_limit_are_refused_with_the_count():
    import scenes

    for shape, res in (("sphere", 1024), ("torus", 600), ("teapot", 200), ("bowl", 1024), ("plane", 1024)):
        # an override, named as typed
        with pytest.raises(SceneError, match=rf"override objects.0.resolution = {res}: a {shape} of \d+ triangles"):
            scenes.load("builtin:sphere-blend").with_overrides({"objects.0.shape": shape, "objects.0.resolution": res})


@pytest.mark.parametrize("name", list(meshes.BUILTIN_MESHES))
def test_builtin_triangle_counts_are_upper_bounds(name):
    for res in (2, 3, 7, 16):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", meshes.MeshWarning)
            m = meshes.BUILTIN_MESHES[name](res)
        assert 0.9 * meshes.builtin_triangles(name, res) <= m.n_triangles <= meshes.builtin_triangles(name, res)


def exhaustive_convex(p, idx) -> bool:
    """The old test: every vertex against every face plane."""
    p = np.asarray(p, np.float64) - np.mean(p, axis=0)
    a = p[idx[:, 0]]
    fn = np.cross(p[idx[:, 1]] - a, p[idx[:, 2]] - a)
    fn /= np.linalg.norm(fn, axis=1, keepdims=True)
    tol = 1e-6 * np.ptp(p, axis=0).max()
    return bool(((p @ fn.T - np.einsum("fk,fk->f", fn, a)) <= tol).all())


def test_fast_convexity_agrees_with_the_exhaustive_test(rng):
    from scipy.spatial import ConvexHull

    tested = 0
    for name, fn in meshes.BUILTIN_MESHES.items():
        for res in (2, 4, 9):
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", meshes.MeshWarning)
                m = fn(res)
            p = m.positions.astype(np.float64)
            for q in (p, p * [1.0, 0.3, 2.0], p + 0.02 * rng.normal(size=p.shape)):
                assert meshes.is_convex(q, m.indices) == exhaustive_convex(q, m.indices), name
                tested += 1
    for _ in range(20):  # random convex hulls, then each with one vertex pushed in or pulled out
        pts = rng.normal(size=(40, 3))
        hull = ConvexHull(pts)
        idx = hull.simplices.copy()
        flip = np.einsum("fk,fk->f", np.cross(pts[idx[:, 1]] - pts[idx[:, 0]], pts[idx[:, 2]] - pts[idx[:, 0]]),
                         hull.equations[:, :3]) < 0
        idx[flip] = idx[flip][:, ::-1]
        assert meshes.is_convex(pts, idx) and exhaustive_convex(pts, idx)
        for factor in (0.5, 0.999, 1.5):
            q = pts.copy()
            q[hull.vertices[0]] *= factor
            assert meshes.is_convex(q, idx) == exhaustive_convex(q, idx)
            tested += 1
    assert tested > 100


def test_a_large_convex_mesh_loads(tmp_path):
    """A 65k-face convex OBJ (the old test took ~30 s for its convexity alone; now well under a second)."""
    m = meshes.sphere(128)
    lines = [f"v {x:.7g} {y:.7g} {z:.7g}" for x, y, z in m.positions]
    lines += [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in m.indices]
    (tmp_path / "s.obj").write_text("\n".join(lines))
    loaded = meshes.load_file(tmp_path / "s.obj")
    assert loaded.convex and loaded.closed and loaded.n_triangles == m.n_triangles


def test_coordinates_beyond_the_limit_are_refused(tmp_path):
    (tmp_path / "b.obj").write_text("v 2e6 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    with pytest.raises(MeshError, match=r"b.obj: vertex coordinates reach 2e\+06"):
        meshes.load_file(tmp_path / "b.obj")


def test_write_env_helper_still_round_trips(tmp_path):
    rgb = np.random.default_rng(0).random((8, 16, 3)).astype(np.float32)
    np.testing.assert_array_equal(envmap.read(write_env(tmp_path / "r.exr", rgb)), rgb)


def _obj_texts(rng) -> list[str]:
    texts = [hostile.GOOD_OBJ, hostile.cube_obj(True), hostile.cube_obj(False), *[t for _, t in hostile.BAD_OBJS],
             "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf -4 -3 -2 -1\n",
             "v 0 0 0 1\nv 1 0 0 1\nv 0 1 0 1\nvt 0 0\nf 1/1 2/1 3/1\n",
             "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvn 0 0 1\nvn 0 0 1\nf 1/1/1 2/1/2 3/1/1\nf 3/1/1 2/1/2 1/1/1\n",
             "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0.5 2 0\nf 1 2 3 5 4\nf 1 3 2\n",
             "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/1 2/ 3\n", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nv 0 0 1\nf -1 -3 -2\n",
             # what trimesh alone misreads: forms mixed at one column count, relative indices with vertices after
             # them, indented or tab-separated lines, comments after values
             "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nv 1 1 1\nv 2 2 0\nvt 0 0\nf 1/1 2/1 3/1\nf 1 2 4 5 6 3\n",
             "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//1 3//1\nv 0 0 1\nv 1 0 1\nv 0 1 1\nf 1 2 3\n",
             "v 0 0 0\nv 1 0 0\nv 0 1 0\nf -3 -2 -1\nv 5 0 0\nv 5 1 0\nv 5 0 1\nf -3 -2 -1\n",
             "v 0 0 0\n  v 1 0 0\nv\t0 1 0\t# a comment\n\tf 1 2 3\n"]
    for form in ("{a}", "{a}//{a}", "{a}/{a}/{a}", "{a}/{a}"):
        lines = []
        for i in range(120):
            (x, y, z), (a, b, c) = rng.normal(size=3), rng.normal(size=3)
            lines += [f"v {x:f} {y:f} {z:f}", f"vn {a:f} {b:f} {c:f}", "vt 0 0"]
            if i >= 5:
                lines.append("f " + " ".join(form.format(a=a) for a in rng.integers(-i, 0, size=rng.integers(3, 7))))
        texts.append("\n".join(lines) + "\n")
    return texts


def _oracle_obj(text: str):
    """A line-by-line OBJ reading (the hand-written reader iblcheck had before trimesh) as triangles:
    (T, 3, 3) corner positions and (T, 3, 3) corner normals (None unless every corner has one); None
    for a file it refuses."""
    v, vn, tris, norms = [], [], [], []
    for line in text.replace("\\\n", "").splitlines():
        parts = line.split("#")[0].split()
        if not parts:
            continue
        try:
            if parts[0] in ("v", "vn"):
                if len(parts) < 4:
                    return None
                (v if parts[0] == "v" else vn).append([float(x) for x in parts[1:4]])
            elif parts[0] == "f":
                if len(parts) < 4:
                    return None
                poly = []
                for ref in parts[1:]:
                    f = ref.split("/")
                    refs = [(int(f[0]), v)] + ([(int(f[2]), vn)] if len(f) > 2 and f[2] else [])
                    got = []
                    for i, pool in refs:
                        k = i - 1 if i > 0 else len(pool) + i
                        if i == 0 or not 0 <= k < len(pool):
                            return None
                        got.append(pool[k])
                    poly.append((got[0], got[1] if len(got) > 1 else None))
                for k in range(1, len(poly) - 1):
                    tris.append([poly[0][0], poly[k][0], poly[k + 1][0]])
                    norms.append([poly[0][1], poly[k][1], poly[k + 1][1]])
        except ValueError:
            return None
    if not tris:
        return None
    with_normals = all(n is not None for tri in norms for n in tri)
    return np.array(tris), (np.array(norms) if with_normals else None)


def _canonical(tris: np.ndarray, normals: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray | None]:
    """Triangles (T, 3, 3) rotated to start at their smallest corner (winding kept) and sorted, with
    their corner normals (T, 3, 3) rotated and sorted alike."""
    tris = np.asarray(tris, dtype=np.float32).astype(np.float64)
    rolls = [min(range(3), key=lambda r, t=t: tuple(t[r])) for t in tris]
    pos = np.stack([np.roll(t, -r, axis=0) for t, r in zip(tris, rolls, strict=True)])
    order = np.lexsort(pos.reshape(-1, 9).T[::-1])
    if normals is None:
        return pos[order], None
    nrm = np.stack([np.roll(n, -r, axis=0) for n, r in zip(normals, rolls, strict=True)])
    return pos[order], nrm[order]


def test_trimesh_reads_what_a_line_by_line_reader_reads(tmp_path, rng):
    """OBJ files, each read through trimesh (with iblcheck's preparation) and by a line-by-line reading:
    the same triangles with the same winding, and the file's normals where every corner has one; or a
    refusal naming the file (where the line reading refuses, always)."""
    same, texts = [], _obj_texts(rng)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", meshes.MeshWarning)
        for k, text in enumerate(texts):
            path = tmp_path / f"x{k}.obj"
            path.write_text(text)
            expected = _oracle_obj(text)
            try:
                mesh = meshes.load_file(path)
            except MeshError as exc:
                assert str(exc).startswith(str(path)) and not hostile.python_text(str(exc)), str(exc)
                continue
            assert expected is not None, text[:200]
            tris, normals = expected
            p = tris.astype(np.float64)
            keep = np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1) > 1e-12
            got, got_n = _canonical(mesh.positions[mesh.indices], mesh.normals[mesh.indices])
            want, want_n = _canonical(tris[keep], None if normals is None else normals[keep])
            np.testing.assert_array_equal(got, want, err_msg=text[:200])
            if want_n is not None:  # per corner, up to the inward flip make_mesh does (and says)
                want_n = want_n / np.linalg.norm(want_n, axis=-1, keepdims=True)
                np.testing.assert_allclose(np.abs(np.einsum("tck,tck->tc", got_n, want_n)), 1.0, atol=1e-5,
                                           err_msg=text[:200])
            same.append(k)
    # every file reads the same but the broken ones and "f 1/1 2/ 3" (corner forms mixed on one line: refused)
    broken = range(3, 3 + len(hostile.BAD_OBJS))
    mixed_on_a_line = 3 + len(hostile.BAD_OBJS) + 4
    assert same == [k for k in range(len(texts)) if k not in broken and k != mixed_on_a_line], same
