"""The light array: an environment map stood in for by N distant lights (docs/contract.md section 9).

Two placements, both exact in power: every light carries the environment's radiance integrated over
its own region of the sphere, so the lights' powers sum to the map's integral for every count.

- `geodesic`: light directions at the vertices of a subdivided polyhedron (tetrahedron 4, octahedron 6,
  icosahedron 12, each subdivision splitting every triangle in four and pushing the midpoints onto the
  sphere: 10, 34, 130, ...; 18, 66, 258, ...; 42, 162, 642, 2562, ...). A light's region is its
  spherical Voronoi cell: the map's texels nearer to it (larger dot product) than to any other light.
- `median_cut` (Debevec 2005, "A median cut algorithm for light probe sampling"): the lat-long map is
  cut recursively, each region along its longer side (the width measured on the sphere, i.e. times
  sin(theta) at the region's middle; along longitude when the two are equal), into two halves of equal
  energy, until there are `count` = 2^k regions (a region cut down to a single texel, e.g. a sun, stays
  whole and others are cut instead); each light sits at its region's energy centroid. The energy of a
  texel is its luminance times its solid angle: without the sin(theta) of the solid angle the cuts
  crowd the poles (a known bug class in lat-long code).

Units: a light's `power` (RGB) is sum over its texels of L * dOmega (W m^-2 sr^-1 * sr = W m^-2): the
irradiance it delivers to a surface facing it, i.e. Mitsuba's `directional` emitter's `irradiance`.
A diffuse surface of albedo kd under the array reflects kd / pi * sum_i power_i max(n . l_i, 0).

The map's integral is the quadrature of scenes/directions.equirect_solid_angles (exact band areas,
summing to 4 pi), the same one the SH projection uses. Directions are in the map's own frame; a map
turned by rotation_deg about +Y turns its lights with it (world = rotation_y(deg) @ d).
All math is float64 numpy; the real-time side re-sums the same texel regions on the GPU every frame
(realtime/techniques/lights/lights.py).
"""

from __future__ import annotations

import hashlib
from collections import OrderedDict, deque
from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from scenes.environment.directions import equirect_directions, equirect_solid_angles, luminance, normalize
from scenes.storage.disk_cache import digest_arrays

PLACEMENTS = ("geodesic", "median_cut")
#: subdivisions of each polyhedron offered (counts up to 10242 lights)
MAX_SUBDIVISIONS = {"tetrahedron": 5, "octahedron": 5, "icosahedron": 5}
MAX_MEDIAN_CUT = 4096

_PHI = (1.0 + 5.0 ** 0.5) / 2.0
_BASES = {
    "tetrahedron": (np.array([[1, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1]], float),
                    np.array([[0, 1, 2], [0, 3, 1], [0, 2, 3], [1, 3, 2]])),
    "octahedron": (np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]], float),
                   np.array([[0, 2, 4], [4, 2, 1], [1, 2, 5], [5, 2, 0],
                             [4, 3, 0], [1, 3, 4], [5, 3, 1], [0, 3, 5]])),
    "icosahedron": (np.array([[-1, _PHI, 0], [1, _PHI, 0], [-1, -_PHI, 0], [1, -_PHI, 0],
                              [0, -1, _PHI], [0, 1, _PHI], [0, -1, -_PHI], [0, 1, -_PHI],
                              [_PHI, 0, -1], [_PHI, 0, 1], [-_PHI, 0, -1], [-_PHI, 0, 1]], float),
                    np.array([[0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11],
                              [1, 5, 9], [5, 11, 4], [11, 10, 2], [10, 7, 6], [7, 1, 8],
                              [3, 9, 4], [3, 4, 2], [3, 2, 6], [3, 6, 8], [3, 8, 9],
                              [4, 9, 5], [2, 4, 11], [6, 2, 10], [8, 6, 7], [9, 8, 1]])),
}


@dataclass(frozen=True)
class LightArray:
    """N distant lights: unit directions (N, 3) toward the light in the map's frame, RGB powers (N, 3)
    (W m^-2, see the module docstring), and for each texel of the map the light whose region holds it."""

    directions: np.ndarray
    powers: np.ndarray
    texel_light: np.ndarray  # (H, W) int32: the light each texel's radiance went into
    placement: str

    @property
    def count(self) -> int:
        return len(self.directions)


def _subdivide(vertices: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Split every triangle in four; midpoints are shared between neighbours and pushed to the sphere."""
    verts = list(vertices)
    midpoint: dict[tuple[int, int], int] = {}

    def mid(a: int, b: int) -> int:
        key = (min(a, b), max(a, b))
        if key not in midpoint:
            midpoint[key] = len(verts)
            verts.append(normalize(vertices[a] + vertices[b]))
        return midpoint[key]

    out = []
    for a, b, c in faces:
        ab, bc, ca = mid(a, b), mid(b, c), mid(c, a)
        out += [(a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca)]
    vertices = np.array(verts)
    return vertices, np.array(out)


def _geodesic_table() -> dict[int, tuple[str, int]]:
    """{light count: (polyhedron, subdivisions)} for every geodesic array offered."""
    table = {}
    for name in ("tetrahedron", "octahedron", "icosahedron"):
        v, f = _BASES[name][0], _BASES[name][1]
        for k in range(MAX_SUBDIVISIONS[name] + 1):
            n_edges = len(f) * 3 // 2
            table.setdefault(len(v), (name, k))
            v = np.zeros((len(v) + n_edges, 3))  # counts only: V' = V + E, F' = 4F
            f = np.zeros((len(f) * 4, 3))
    return dict(sorted(table.items()))


GEODESIC_COUNTS: dict[int, tuple[str, int]] = _geodesic_table()


def count_problem(placement: str, count: int) -> str | None:
    """Why `count` lights cannot be placed by `placement` (None when they can)."""
    if placement == "geodesic" and count not in GEODESIC_COUNTS:
        return "a geodesic array has one of " + ", ".join(map(str, GEODESIC_COUNTS)) + " lights"
    if placement == "median_cut" and (count < 1 or count > MAX_MEDIAN_CUT or count & (count - 1)):
        return f"median cut makes a power of two of lights, 1 ... {MAX_MEDIAN_CUT}"
    return None


def geodesic_directions(count: int) -> np.ndarray:
    """Unit directions (count, 3) at the vertices of the subdivided polyhedron with `count` vertices."""
    problem = count_problem("geodesic", count)
    if problem:
        raise ValueError(f"{count} lights: {problem}")
    name, k = GEODESIC_COUNTS[count]
    v, f = normalize(_BASES[name][0]), _BASES[name][1]
    for _ in range(k):
        v, f = _subdivide(v, f)
    return v


def nearest_light(directions: np.ndarray, lights: np.ndarray) -> np.ndarray:
    """Index of the light with the largest dot product for each direction (..., 3): its Voronoi cell."""
    # on the unit sphere the Euclidean nearest neighbour is the largest dot product
    flat = directions.reshape(-1, 3)
    _, idx = cKDTree(lights).query(flat, k=1)
    return idx.reshape(directions.shape[:-1]).astype(np.int32)


def region_powers(env: np.ndarray, texel_light: np.ndarray, count: int) -> np.ndarray:
    """RGB power (count, 3) of each light: sum of L * dOmega over the texels assigned to it (float64)."""
    h, w = env.shape[:2]
    weighted = env.astype(np.float64) * equirect_solid_angles(h, w)[..., None]
    return np.stack([np.bincount(texel_light.ravel(), weighted[..., c].ravel(), minlength=count)
                     for c in range(3)], axis=1)


def map_integral(env: np.ndarray) -> np.ndarray:
    """The map's integral over the sphere, RGB (the same quadrature as region_powers)."""
    h, w = env.shape[:2]
    return (env.astype(np.float64) * equirect_solid_angles(h, w)[..., None]).sum(axis=(0, 1))


def geodesic(env: np.ndarray, count: int) -> LightArray:
    """The geodesic array of `count` lights for an equirect map (H, W, 3)."""
    lights = geodesic_directions(count)
    h, w = env.shape[:2]
    texel_light = nearest_light(equirect_directions(h, w), lights)
    return LightArray(lights, region_powers(env, texel_light, count), texel_light, "geodesic")


def _median_cut_regions(energy: np.ndarray, count: int) -> list[tuple[int, int, int, int]]:
    """Debevec's cuts: rectangles (r0, r1, c0, c1) (half-open) of the lat-long map, `count` of them."""
    h, w = energy.shape
    sat = np.zeros((h + 1, w + 1))
    sat[1:, 1:] = energy.cumsum(0).cumsum(1)

    def total(r0: int, r1: int, c0: int, c1: int) -> float:
        return sat[r1, c1] - sat[r0, c1] - sat[r1, c0] + sat[r0, c0]

    def split(r0: int, r1: int, c0: int, c1: int):
        theta = np.pi * ((r0 + r1 - 1) / 2.0) / max(h - 1, 1)
        width = (c1 - c0) / w * 2.0 * np.pi * np.sin(theta)  # the region's extent on the sphere
        height = (r1 - r0) / max(h - 1, 1) * np.pi
        by_cols = (width >= height and c1 - c0 > 1) or r1 - r0 < 2
        lo, hi = (c0, c1) if by_cols else (r0, r1)
        if hi - lo < 2:
            return None  # a single texel
        half = total(r0, r1, c0, c1) / 2.0
        cuts = np.arange(lo + 1, hi)
        partial = np.array([total(r0, r1, c0, k) if by_cols else total(r0, k, c0, c1) for k in cuts])
        # the cut whose first part is nearest half the energy (a black region is cut in the middle)
        k = int(cuts[np.argmin(np.abs(partial - half))]) if half > 0 else (lo + hi) // 2
        return ((r0, r1, c0, k), (r0, r1, k, c1)) if by_cols else ((r0, k, c0, c1), (k, r1, c0, c1))

    # breadth first, so that with every region splittable the cuts are Debevec's generations; a single
    # texel (a sun cut down to its pixel) stays whole and the next regions are cut instead
    queue, whole = deque([(0, h, 0, w)]), []
    while len(queue) + len(whole) < count:
        if not queue:
            raise ValueError(f"median cut: {count} lights need more texels than the map's {h}x{w}")
        region = queue.popleft()
        parts = split(*region)
        if parts is None:
            whole.append(region)
        else:
            queue.extend(parts)
    return [*whole, *queue]


def median_cut(env: np.ndarray, count: int) -> LightArray:
    """Debevec's median-cut array of `count` (a power of two) lights for an equirect map (H, W, 3).

    Each light sits along its region's energy centroid (a black region's solid-angle centroid); a region
    whose centroid vanishes (one light for a map symmetric about the centre, such as a uniform one) puts
    its light at its middle texel."""
    problem = count_problem("median_cut", count)
    if problem:
        raise ValueError(f"{count} lights: {problem}")
    h, w = env.shape[:2]
    omega = equirect_solid_angles(h, w)
    energy = luminance(env.astype(np.float64)) * omega
    dirs = equirect_directions(h, w)
    texel_light = np.empty((h, w), np.int32)
    lights = np.empty((count, 3))
    for i, (r0, r1, c0, c1) in enumerate(_median_cut_regions(energy, count)):
        texel_light[r0:r1, c0:c1] = i
        e = energy[r0:r1, c0:c1]
        weight = e if e.sum() > 0 else omega[r0:r1, c0:c1]  # a black region: its geometric centre
        centroid = (dirs[r0:r1, c0:c1] * weight[..., None]).sum(axis=(0, 1))
        # a region symmetric about the centre (the whole sphere): its centroid is rounding residue, at most
        # a few ulps of the weight, and its light sits at the middle texel instead
        if np.linalg.norm(centroid) <= 1e-9 * weight.sum():
            centroid = dirs[(r0 + r1) // 2, (c0 + c1) // 2]
        lights[i] = normalize(centroid)
    return LightArray(lights, region_powers(env, texel_light, count), texel_light, "median_cut")


def make(env: np.ndarray, placement: str, count: int) -> LightArray:
    """The light array of a scene's `[realtime.lights]` table."""
    if placement == "geodesic":
        return geodesic(env, count)
    if placement == "median_cut":
        return median_cut(env, count)
    raise ValueError(f"light placement {placement!r}: one of {', '.join(PLACEMENTS)}")


#: digests of arrays already made in this process: {(the map's SHA-256, placement, count): digest}
_DIGESTS: OrderedDict[tuple[str, str, int], str] = OrderedDict()
_DIGESTS_KEPT = 64


def content_digest(env: np.ndarray, placement: str, count: int) -> str:
    """Hex SHA-256 of the array's directions and powers for a map (H, W, 3): what a reference rendered
    with the array (reference.lighting = "light_array") depends on, so that the reference cache and
    the result rows are keyed by the array itself, not by the code that places it. The arrays are
    digested in float32, the precision Mitsuba's emitters and the GPU take them in (so a last-bit
    difference of float64 sums between two machines does not split the key). Made once per map,
    placement and count in a process (the map's bytes are hashed to find it)."""
    h = hashlib.sha256()
    digest_arrays(h, env)
    key = (h.hexdigest(), placement, int(count))
    if key not in _DIGESTS:
        array = make(env, placement, count)
        h = hashlib.sha256()
        digest_arrays(h, array.directions.astype(np.float32), array.powers.astype(np.float32))
        _DIGESTS[key] = h.hexdigest()
        while len(_DIGESTS) > _DIGESTS_KEPT:
            _DIGESTS.popitem(last=False)
    return _DIGESTS[key]


def diffuse_irradiance(lights: LightArray, normals: np.ndarray) -> np.ndarray:
    """E(n) = sum_i power_i max(n . l_i, 0), RGB (..., 3): what the array delivers to unoccluded normals."""
    cos = np.maximum(np.asarray(normals, float) @ lights.directions.T, 0.0)
    return cos @ lights.powers
