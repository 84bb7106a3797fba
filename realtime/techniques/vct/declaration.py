"""`realtime.occlusion = "vct"` and `realtime.interreflection = "vct"`: voxel cone tracing, declared as data
(scenes/model/technique_registry.py); the OpenGL half is vct.py, its numpy half vct_math.py. Both read
[realtime.vct] and share one voxel scene per frame."""

from __future__ import annotations

from dataclasses import asdict, dataclass

from scenes.model.technique_registry import (
    Declaration,
    combination_error,
    int_choice,
    number,
    one_of,
    param,
    power_of_two,
)


@dataclass(frozen=True)
class Vct:
    """[realtime.vct]: voxel cone tracing (vct.py, vct_math.py)."""
    resolution: int = param(64, power_of_two(8, 256))
    cascades: int = param(3, number(1, 4, integer=True))
    diffuse_cones: int = param(6, int_choice(4, 6, 9))
    step: float = param(0.5, number(0, 4, lo_open=True))
    bounces: int = param(1, number(1, 4, integer=True))
    #: how a cone reads a glossy surface's reflection of the environment: "deferred" evaluates it toward the cone
    #: (vct_trace.glsl's vct_gloss_radiance), "six_faces" reads it as stored toward the faces' six axes
    glossy_read: str = param("deferred", one_of("deferred", "six_faces"))


def validate(rt, given: dict, where: str) -> None:
    if rt.interreflection == "vct" and rt.occlusion != "vct":
        raise combination_error(rt, "interreflection", "occlusion", "light gathered from the voxels replaces the "
                                'environment they block: set realtime.occlusion = "vct"', where)


def describe(rt) -> dict:
    """The table as set; `bounces` and `glossy_read` (added later) only where they are not their defaults, so
    that rows described before they existed describe alike."""
    table = asdict(rt.vct)
    if table["bounces"] == 1:
        del table["bounces"]
    if table["glossy_read"] == "deferred":
        del table["glossy_read"]
    return {"vct": table}


#: 1: the glossy terms scaled by the Phong lobe's share above the horizon (vct_math.lobe_above_horizon);
#: 2: a texel showing a cone its lit surface's back adds no light (vct_trace.glsl's vct_axis_facing);
#: 3: per-face normals: a face adds light only where its surfaces face the cone, and the facing sum counts a
#: black face only where a normal is stored on it, a surface facing the cone on that axis (vct_read);
#: 4: an axis's coverage blocks a cone only where a surface covering that axis faces it (vct_facing_axes);
#: 5: the bounce passes' cones read no cascade's level 0, which those passes rewrite (with cascades >= 2 they
#: read a coarser cascade's level 0 while it was written: bounces >= 2 with cascades >= 2 change);
#: 6: the faces' radiance scaled into half float's range under a bright environment (vct_math.radiance_scale),
#: a stored normal told from the empty one with a tolerance (images of ordinary scenes within 1.2e-7), and the
#: bounce passes' cones take their opacity where the direct pass's do (bounces >= 2 change), and the voxeliser's
#: fixed-point sums scaled down where a crowded voxel could overflow them;
#: 7: a cone's samples bounded so that it always reaches the outermost cascade's boundary
#: (vct_math.max_cone_samples; a fixed 512 had cut cones grazing a surface short, which then read open sky
#: beyond: only those change, ordinary images are bit-identical)
#: 8: the deferred glossy read: where a scene has glossy surfaces, a cone evaluates their environment term toward
#: itself from a stored lobe weight and exponent (vct_trace.glsl's vct_gloss_radiance) instead of reading the
#: faces' six stored directions (scenes without glossy surfaces are unchanged)
#: 9: the deferred glossy read takes the mean of the reflections over the reading cone's directions and over the
#: spread of the normals a face stands for (vct_trace.glsl's vct_broadened_exponent; the normal textures' alpha
#: stores the spread): scenes without glossy surfaces are unchanged
#: 10: the diffuse cones' ring and weights those that integrate every radiance of spherical-harmonic order <= 2
#: exactly (vct_math.cone_set: six cones' ring at 49.9 deg, where the seed's was at 60 deg with Voronoi weights)
#: 11: the environment's chain the cones read (the injection's glossy lobe, the deferred glossy read) weighted by
#: solid angle (gpu.py's EnvironmentFilter.solid_angle_chain), where the paper's box chain weighs a cube face's
#: corner texels as its centre's: scenes without glossy surfaces are unchanged
#: 12: the glossy reads' lobes below N = 255 from the broad-lobe table (lobe_table.py), the lobe's integral over
#: the environment, where a chain texel's box mean had stood for it: scenes without glossy surfaces are unchanged
MODEL_VERSION = 12
_COMMON = dict(table="vct", parameters=Vct, table_hint='realtime.occlusion or interreflection = "vct"',
               model_version=MODEL_VERSION,
               timing_key="voxelize", extra_timing_keys=("mip",), package=__package__,
               fragment_glsl=("vct.glsl",), shade_entry="vct_shade", describe=describe)
DECLARATIONS = (
    Declaration(
        **_COMMON, effect="occlusion", name="vct", rank=30, simulates=frozenset({"occlusion"}),
        implementation="realtime.techniques.vct.vct:VctOcclusion",
        reads=("realtime.vct.resolution", "realtime.vct.cascades", "realtime.vct.diffuse_cones",
               "realtime.vct.step", "realtime.vct.bounces", "realtime.vct.glossy_read"),
        axes={"realtime.vct.resolution": (32, 64, 128), "realtime.vct.cascades": (1, 2, 3),
              "realtime.vct.diffuse_cones": (4, 6, 9)},
        validate=validate,
    ),
    Declaration(
        **_COMMON, effect="interreflection", name="vct", rank=20, simulates=frozenset({"interreflection"}),
        implementation="realtime.techniques.vct.vct:VctInterreflection",
    ),
)
