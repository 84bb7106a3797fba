"""The light array's math (scenes/environment/light_array.py) against independent expectations.

- Powers: the lights' powers sum to the map's integral (the band-area quadrature, 4 pi for radiance 1)
  for every count of both placements, on random high-dynamic-range maps.
- Geodesic directions: unit, distinct, and as evenly spread as the polyhedron promises.
- A constant environment of radiance 1 under the geodesic array gives a diffuse surface E = pi within
  the discretisation error of the cosine sum: every light stands for its cell's solid angle at one
  direction; the error shrinks about as 1/N (the cell's area: the clamped cosine is linear inside a
  cell that does not cross the horizon, so only its first moment and the horizon cells err). The
  largest error over 20,000 random normals is 4.1% at 42, 1.03% at 162 and 0.25% at 642 lights; the
  bounds, with margin, are 5%, 1.5% and the issue's 1%.
- Median cut weighs texels by solid angle (sin theta): on a constant map every region holds the same
  solid angle; without sin theta the cuts would crowd the poles. On a sky above a black ground the
  cuts, the regions' powers and the lights' elevations are worked out by hand (bands of equal sky
  solid angle, closed-form centroids), and a green/blue map is cut where Rec. 709 luminance says.
"""

from __future__ import annotations

import numpy as np
import pytest

from scenes.environment import light_array
from scenes.environment.directions import equirect_directions, equirect_solid_angles


def random_map(seed: int, h: int = 32, w: int = 64) -> np.ndarray:
    """Lognormal radiance with a bright sun: seven orders of magnitude."""
    rng = np.random.default_rng(seed)
    env = rng.lognormal(0.0, 2.0, size=(h, w, 3)).astype(np.float32)
    env[rng.integers(h), rng.integers(w)] = 1e5
    return env


GEODESIC = [n for n in light_array.GEODESIC_COUNTS if n <= 642]
MEDIAN = [1, 2, 4, 16, 64, 256]


@pytest.mark.parametrize("seed", [0, 1])
@pytest.mark.parametrize("placement,count", [("geodesic", n) for n in GEODESIC] + [("median_cut", n) for n in MEDIAN])
def test_powers_sum_to_the_map_integral(seed, placement, count):
    env = random_map(seed)
    array = light_array.make(env, placement, count)
    # the integral computed here, independently: radiance times the exact band areas
    h, w = env.shape[:2]
    dt = np.pi / (h - 1)
    theta = np.arange(h) * dt
    band = np.cos(np.clip(theta - dt / 2, 0, np.pi)) - np.cos(np.clip(theta + dt / 2, 0, np.pi))
    integral = (env.astype(np.float64) * (band[:, None, None] * 2 * np.pi / w)).sum(axis=(0, 1))
    assert array.count == count
    np.testing.assert_allclose(array.powers.sum(axis=0), integral, rtol=1e-5)
    assert (array.powers >= 0).all()


@pytest.mark.parametrize("count", GEODESIC)
def test_geodesic_directions_are_unit_distinct_and_spread(count):
    d = light_array.geodesic_directions(count)
    assert d.shape == (count, 3)
    np.testing.assert_allclose(np.linalg.norm(d, axis=1), 1.0, atol=1e-12)
    cos = d @ d.T
    np.fill_diagonal(cos, -1.0)
    nearest = np.arccos(np.clip(cos.max(axis=1), -1, 1))
    # evenly spread: no two lights closer than half the spacing of N evenly spread points
    # (sqrt(4 pi / N) rad); how much the spacing varies depends on the polyhedron: subdividing pushes
    # midpoints out by different amounts where the base's faces are large, so a subdivided icosahedron
    # (the seed's choice) stays within 25%, an octahedron within 60% and a tetrahedron only within 2.5x
    assert nearest.min() > 0.5 * np.sqrt(4 * np.pi / count)
    spread = {"icosahedron": 1.25, "octahedron": 1.6, "tetrahedron": 2.5}[light_array.GEODESIC_COUNTS[count][0]]
    assert nearest.max() < spread * nearest.min()


@pytest.mark.parametrize("count", [5, 41, 43, 100, 643])
def test_a_count_no_polyhedron_has_is_refused_with_the_list(count):
    with pytest.raises(ValueError, match="42, 66"):
        light_array.geodesic_directions(count)
    assert "42" in light_array.count_problem("geodesic", count)


@pytest.mark.parametrize("count", [3, 6, 100, 8192])
def test_median_cut_needs_a_power_of_two(count):
    assert light_array.count_problem("median_cut", count) is not None
    with pytest.raises(ValueError, match="power of two"):
        light_array.median_cut(random_map(0), count)


@pytest.mark.parametrize("count,bound", [(42, 0.05), (162, 0.015), (642, 0.01)])
def test_constant_environment_lights_a_diffuse_surface_to_pi(count, bound):
    env = np.ones((128, 256, 3), np.float32)
    array = light_array.geodesic(env, count)
    rng = np.random.default_rng(7)
    n = rng.normal(size=(20000, 3))
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    e = light_array.diffuse_irradiance(array, n)
    assert np.abs(e / np.pi - 1.0).max() < bound


def test_median_cut_regions_hold_equal_solid_angle_on_a_constant_map():
    h, w = 128, 256
    env = np.ones((h, w, 3), np.float32)
    array = light_array.median_cut(env, 16)
    omega = np.bincount(array.texel_light.ravel(), equirect_solid_angles(h, w).ravel(), minlength=16)
    # equal energy = equal solid angle here; a cut is quantised to one texel row or column
    np.testing.assert_allclose(omega, 4 * np.pi / 16, rtol=0.05)
    # and the lights spread over the sphere: as many above the equator as below
    assert (array.directions[:, 1] > 0).sum() == 8


def test_median_cut_puts_one_light_on_a_dominant_sun():
    h, w = 64, 128
    env = np.full((h, w, 3), 1e-3, np.float32)
    env[20, 37] = 1e6
    sun = equirect_directions(h, w)[20, 37]
    array = light_array.median_cut(env, 1)
    assert float(array.directions[0] @ sun) > np.cos(np.radians(1.0))


def test_voronoi_cells_assign_every_texel_to_its_nearest_light():
    env = random_map(3)
    array = light_array.geodesic(env, 42)
    dirs = equirect_directions(*env.shape[:2]).reshape(-1, 3)
    brute = np.argmax(dirs @ array.directions.T, axis=1)  # the definition, all pairs
    np.testing.assert_array_equal(array.texel_light.ravel(), brute)


def _wedge_centroid_elevation(a: float, b: float, wedge: float) -> float:
    """Elevation (radians) of the mean direction of the band of polar angle [a, b] in an azimuth wedge
    of width `wedge`, by the closed-form integrals of (sin t cos p, cos t, sin t sin p) sin t dt dp:
    vertical  int cos t sin t dt = (sin^2 b - sin^2 a) / 2 over the wedge's width,
    horizontal  int sin^2 t dt = (b - a) / 2 - (sin 2b - sin 2a) / 4, times |int e^{ip} dp| = 2 sin(wedge / 2)."""
    vertical = (np.sin(b) ** 2 - np.sin(a) ** 2) / 2.0 * wedge
    horizontal = ((b - a) / 2.0 - (np.sin(2 * b) - np.sin(2 * a)) / 4.0) * 2.0 * np.sin(wedge / 2.0)
    return float(np.arctan2(vertical, horizontal))


def test_median_cut_cuts_a_sky_into_equal_solid_angles_of_sky():
    """A map of radiance 1 above the horizon and 0 below, cut into 16 lights. Worked out by hand from
    the cut rule (each region along its longer side on the sphere, at half its energy = L dOmega):
    the whole map (2 pi x pi) is cut in two halves of longitude; a half (pi wide at the equator,
    pi tall) at 60 deg, where the sky above it holds half its solid angle (cos theta = 1/2); the cap
    (pi sin 30 deg wide, pi/3 tall) and the rest (pi sin 120 deg wide, 2 pi/3 tall) along longitude;
    then each quarter wedge of the cap (pi/2 sin 30 deg wide, shorter than its pi/3) and of the rest
    along latitude. So 16 rectangles: 4 wedges of 90 deg times the bands of equal sky solid angle,
    cos theta in [1, 3/4], [3/4, 1/2], [1/2, 1/4], [1/4, 0] (the last with the black ground below),
    each of power 2 pi / 16, each light at the sky's centroid of its band (closed form).
    Without the sin theta of the solid angle the cut would fall at 45 deg, without the sin theta of
    the width the cap's wedges would be cut along longitude, and the black ground would pull the last
    band's light below the horizon if the centroid were geometric."""
    h, w, count = 256, 512, 16
    theta = np.arange(h) * np.pi / (h - 1)  # row r at theta = pi r / (H - 1); the band of row 127 ends at 90 deg
    env = np.where(theta[:, None, None] < np.pi / 2, 1.0, 0.0) * np.ones((h, w, 3))
    array = light_array.median_cut(env.astype(np.float32), count)
    edges = np.arccos([1.0, 0.75, 0.5, 0.25, 0.0])  # the sky's bands of equal solid angle
    row_edge = edges * (h - 1) / np.pi + 0.5  # a band's first row: the first texel centre below its edge
    found = set()
    for i in range(count):
        rows, cols = np.nonzero(array.texel_light == i)
        r0, r1, c0, c1 = rows.min(), rows.max() + 1, cols.min(), cols.max() + 1
        assert len(rows) == (r1 - r0) * (c1 - c0), f"light {i}: its texels are no rectangle"
        assert c1 - c0 == w // 4 and c0 % (w // 4) == 0, f"light {i}: columns {c0}..{c1} are not a quarter"
        band = int(np.argmin(np.abs(row_edge[:4] - r0)))
        assert abs(r0 - row_edge[band]) <= 1.0, f"light {i}: first row {r0}, expected {row_edge[band]:.1f}"
        if band < 3:
            assert abs(r1 - row_edge[band + 1]) <= 1.0, f"light {i}: last row {r1}, expected {row_edge[band + 1]:.1f}"
        else:
            assert r1 == h  # the last band holds the ground down to the pole
        found.add((band, c0))
        elevation = np.arcsin(np.clip(array.directions[i, 1], -1.0, 1.0))
        want = _wedge_centroid_elevation(edges[band], edges[band + 1], np.pi / 2)
        assert abs(elevation - want) < np.radians(1.0), f"light {i}: {np.degrees(elevation):.2f} deg, " \
                                                       f"expected {np.degrees(want):.2f}"
    assert len(found) == count  # every wedge and band once
    # a cut is within half a row of its band's edge: half of (2 pi / 4) dtheta = 0.0097 sr of 0.39, 2.5%
    np.testing.assert_allclose(array.powers, 2 * np.pi / count, rtol=0.03)


def test_median_cut_weighs_texels_by_luminance():
    """Left half of the map pure green, right half pure blue (radiance 1), cut once (2 lights): the
    first cut runs along longitude at the column k where the luminance energy left of it is half the
    total. Every column holds the same solid angle, so by hand with Rec. 709's weights (G 0.7152,
    B 0.0722): 0.7152 k = (W / 2)(0.7152 + 0.0722) / 2, k = W (0.7874) / (4 * 0.7152) = 55.05 for
    W = 200. The sum (or mean) of the channels would cut at 100, Rec. 601's weights at 59.7. The
    lights' RGB powers are the regions' radiance times their solid angle, 4 pi per full map."""
    h, w = 64, 200
    env = np.zeros((h, w, 3), np.float32)
    env[:, : w // 2, 1] = 1.0
    env[:, w // 2:, 2] = 1.0
    k_exact = w * (0.7152 + 0.0722) / (4 * 0.7152)
    k = round(k_exact)
    assert abs(k_exact - k) < 0.1  # the nearest column cut is unambiguous
    array = light_array.median_cut(env, 2)
    left = array.texel_light[0, 0]
    np.testing.assert_array_equal(array.texel_light[:, :k], left)
    np.testing.assert_array_equal(array.texel_light[:, k:], 1 - left)
    np.testing.assert_allclose(array.powers[left], [0.0, 4 * np.pi * k / w, 0.0], atol=1e-9)
    np.testing.assert_allclose(array.powers[1 - left], [0.0, 4 * np.pi * (w / 2 - k) / w, 2 * np.pi], atol=1e-9)


@pytest.mark.parametrize(("h", "w"), [(2, 1), (2, 4), (8, 1), (8, 2), (4, 4)])
def test_median_cut_with_as_many_lights_as_texels_gives_each_texel_its_own(h, w):
    """A map of h x w texels cut into h w lights (a power of two): every region is a single texel, whatever
    the order of the cuts (a region of two texels along the cut side must still be cut)."""
    regions = light_array._median_cut_regions(equirect_solid_angles(h, w), h * w)
    assert sorted(regions) == [(r, r + 1, c, c + 1) for r in range(h) for c in range(w)]


# Uniform maps (energy = solid angle), cut by hand. Rows sit at theta = pi r / (H - 1); a region's width on
# the sphere is its share of 2 pi times sin(theta) at its middle row, its height its rows times pi / (H - 1).
MEDIAN_CUT_BY_HAND = [
    # 3 x 4, 2 lights: the map is 2 pi wide at the equator and 3 pi / 2 tall: cut along longitude, in halves
    (3, 4, 2, [(0, 3, 0, 2), (0, 3, 2, 4)]),
    # 4 x 4, 8 lights. Row bands (1 - cos 30, cos 30, cos 30, 1 - cos 30) x 2 pi / 4 per texel. The map (2 pi
    # by 4 pi / 3) in longitude halves; a half (pi wide at the equator, 4 pi / 3 tall) at row 2, where half
    # its energy lies; a quarter (rows 0-1: pi / 2 wide at 30 degrees, 2 pi / 3 tall) along latitude again,
    # into single rows. Without sin(theta), or at another row's theta, the quarters would be cut in columns.
    (4, 4, 8, [(r, r + 1, c, c + 2) for r in range(4) for c in (0, 2)]),
    # 2 x 4, 4 lights: two polar rows, each band of pi / 2 holding half the sphere. Whichever side goes
    # first, the result is the four half-rows (a single row can only be cut in columns).
    (2, 4, 4, [(0, 1, 0, 2), (0, 1, 2, 4), (1, 2, 0, 2), (1, 2, 2, 4)]),
    # 8 x 2, 8 lights. Row bands (0.0251, 0.1931, 0.3480, 0.4339, 0.4339, 0.3480, 0.1931, 0.0251) (sum 2).
    # The map (2 pi by 8 pi / 7) in its two columns; a column (pi by 8 pi / 7) at row 4 (half: 1.0); a
    # quarter, rows 0-3 (one column: only latitude cuts), nearest its half 0.5 after row 3 (0.566) rather
    # than row 2 (0.218); rows 4-7 likewise before row 5.
    (8, 2, 8, [(r0, r1, c, c + 1) for r0, r1 in ((0, 3), (3, 4), (4, 5), (5, 8)) for c in (0, 1)]),
]


@pytest.mark.parametrize(("h", "w", "count", "want"), MEDIAN_CUT_BY_HAND)
def test_median_cut_cuts_along_the_longer_side_on_the_sphere(h, w, count, want):
    """Median cut of small uniform maps against the cuts worked out by hand (beside each case): each region
    is cut along its longer side measured on the sphere, at the cut nearest half its energy."""
    assert sorted(light_array._median_cut_regions(equirect_solid_angles(h, w), count)) == sorted(want)


def test_median_cut_cuts_equal_sides_along_longitude():
    """A region as wide as it is tall on the sphere is cut along longitude (into columns): the 2 x 2 map
    (two polar rows) is 2 pi wide at its middle, the equator, and 2 pi / (2 - 1) = 2 pi tall. Cut into
    columns its halves are two meridian strips, cut into rows they would be the two polar bands."""
    regions = light_array._median_cut_regions(equirect_solid_angles(2, 2), 2)
    assert sorted(regions) == [(0, 2, 0, 1), (0, 2, 1, 2)]


@pytest.mark.parametrize("where", ["first column", "random"])
def test_median_cut_regions_tile_the_map(where):
    """The regions are non-empty rectangles inside the map that cover every texel exactly once: on a black
    map with a single bright texel in the first column (every cut of the first region leaves the sun on
    the same side, none is nearer half its energy than the first one) and on a random map."""
    h, w, count = 8, 16, 8
    if where == "first column":
        energy = np.zeros((h, w))
        energy[3, 0] = 1.0
    else:
        energy = np.random.default_rng(5).random((h, w))
    cover = np.zeros((h, w), int)
    regions = light_array._median_cut_regions(energy, count)
    assert len(regions) == count
    for r0, r1, c0, c1 in regions:
        assert 0 <= r0 < r1 <= h and 0 <= c0 < c1 <= w, (r0, r1, c0, c1)
        cover[r0:r1, c0:c1] += 1
    np.testing.assert_array_equal(cover, 1)


def test_median_cut_of_a_black_map_cuts_in_the_middle_and_lights_the_geometric_centres():
    """A black map (no energy to balance) is cut in the middle of each region, and each light sits at its
    region's geometric centre (the solid-angle centroid). By hand for 16 x 32 and 4 lights: the map in
    longitude halves at column 16, each half (pi by 16 pi / 15) at row 8, so quadrants of a hemisphere by a
    half-turn of azimuth, rows 0-7 the bands down to 90 degrees. Their centroid: in the middle of the
    half's azimuths, at an elevation of +-45 degrees by the closed form (within the texel quadrature's
    0.2 degrees). The middle texel instead (row 4, column 8) would sit 42 degrees up and 5.6 degrees off
    in azimuth (half a texel)."""
    h, w = 16, 32
    array = light_array.median_cut(np.zeros((h, w, 3), np.float32), 4)
    quadrants = {(int(array.texel_light[r, c]), r // 8, c // 16) for r in range(h) for c in range(w)}
    assert len(quadrants) == 4 and len({q[0] for q in quadrants}) == 4  # one light per quadrant, each whole
    want = _wedge_centroid_elevation(0.0, np.pi / 2, np.pi)
    assert want == pytest.approx(np.pi / 4, abs=1e-12)
    dirs = equirect_directions(h, w)
    for light, top, right in quadrants:
        d = array.directions[light]
        elevation = np.arcsin(np.clip(d[1], -1.0, 1.0))
        assert elevation == pytest.approx(want if top == 0 else -want, abs=np.radians(0.25))
        # the azimuth in the middle of the half's columns: along the sum of its directions, made horizontal
        middle = dirs[:, 16 * right:16 * right + 16].sum(axis=(0, 1)) * [1.0, 0.0, 1.0]
        horizontal = d * [1.0, 0.0, 1.0]
        cos = np.dot(horizontal, middle) / np.linalg.norm(horizontal) / np.linalg.norm(middle)
        assert cos == pytest.approx(1.0, abs=1e-12)
    assert np.cos(2 * np.pi / 64) < 1.0 - 1e-3  # half a texel of azimuth is far beyond that tolerance
    np.testing.assert_array_equal(array.powers, 0.0)


@pytest.mark.parametrize(("h", "w"), [(2, 4), (4, 8), (5, 8), (8, 16)])
@pytest.mark.parametrize("value", [0.0, 1.0, 1e6, 1e-6])
def test_a_single_median_cut_light_on_a_symmetric_map_sits_at_the_middle_texel(h, w, value):
    """One light for a uniform (or black) map: the whole sphere is its region, whose centroid is zero up to
    rounding, so the light sits at the middle texel (row h // 2, column w // 2) rather than along the
    rounding residue, however bright the map (the residue grows with the weights, so what counts as zero
    must grow with them too: a sun-bright 1e6 map and a dim 1e-6 one). By hand its height is
    y = cos(pi (h // 2) / (h - 1)): -1, -0.5, 0, -cos(pi / 7)... The
    texel a third of the way (row h // 3, column w // 3) is a different direction on these maps."""
    array = light_array.median_cut(np.full((h, w, 3), value, np.float32), 1)
    dirs = equirect_directions(h, w)
    d = array.directions[0]
    assert d[1] == pytest.approx(np.cos(np.pi * (h // 2) / (h - 1)), abs=1e-12)
    np.testing.assert_allclose(d, dirs[h // 2, w // 2], atol=1e-12)
    assert np.abs(dirs[h // 3, w // 3] - d).max() > 0.1
    assert array.placement == "median_cut"


def test_map_integral_per_channel_by_hand():
    """The integral over the sphere of a constant map (1, 2, 0) is (4 pi, 8 pi, 0) per channel (the solid
    angles of the quadrature sum to 4 pi), on a map whose width and height differ."""
    env = np.empty((6, 10, 3), np.float32)
    env[...] = (1.0, 2.0, 0.0)
    np.testing.assert_allclose(light_array.map_integral(env), [4 * np.pi, 8 * np.pi, 0.0], atol=1e-12)


def test_geodesic_powers_have_a_row_for_every_light_even_without_texels():
    """More lights than texels (a 2 x 4 map, 42 lights): the lights that no texel is nearest to carry no
    power, but each light still has its RGB row, and the rows sum to the map's integral (4 pi per channel
    for a map of ones)."""
    array = light_array.geodesic(np.ones((2, 4, 3), np.float32), 42)
    assert array.powers.shape == (42, 3)
    assert (array.powers == 0).all(axis=1).sum() >= 42 - 8
    np.testing.assert_allclose(array.powers.sum(axis=0), 4 * np.pi, atol=1e-12)
