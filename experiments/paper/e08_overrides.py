"""E8's configurations as scene overrides: the light array (with shadow maps), SH PRT and wavelet PRT. Shared by
the occlusion part (e08_occlusion) and the sharp-shadow part (e08_sharp_shadows)."""

from __future__ import annotations

from scenes.model.scene import MAX_SHADOW_TEXELS


def lights_ov(scene, placement: str, count: int, shadow: int | None = None) -> dict:
    """The light array for every lobe the scene has (a blend: diffuse and glossy), with shadow maps."""
    ov = {"realtime.lights.placement": placement, "realtime.lights.count": count}
    for lobe in ("diffuse", "glossy"):
        if lobe in scene.effects:
            ov[f"realtime.{lobe}"] = "lights"
    if shadow:
        ov.update({"realtime.occlusion": "shadow_maps", "realtime.lights.shadow_map_size": shadow})
    return ov


def prt_ov(order: int, rays: int, bounces: int) -> dict:
    """Shadowed SH PRT of `order` with `rays` visibility rays, interreflected when `bounces` > 0."""
    ov = {"realtime.diffuse": "prt", "realtime.occlusion": "prt", "realtime.prt.order": order,
          "realtime.prt.rays": rays}
    if bounces:
        ov.update({"realtime.interreflection": "prt", "realtime.prt.bounces": bounces})
    return ov


def wavelet_ov(cube_size: int, terms: int, bounces: int) -> dict:
    """Shadowed wavelet PRT on a cube of `cube_size`, K = `terms` lighting terms, interreflected when `bounces` > 0."""
    ov = {"realtime.diffuse": "wavelet_prt", "realtime.occlusion": "wavelet_prt",
          "realtime.wavelet_prt.cube_size": cube_size, "realtime.wavelet_prt.terms": terms}
    if bounces:
        ov.update({"realtime.interreflection": "wavelet_prt", "realtime.wavelet_prt.bounces": bounces})
    return ov


def lights_label(t: dict) -> str | None:
    """The label of a row whose techniques `t` use the light array (with its shadow maps); None otherwise."""
    if "lights" not in (t.get("diffuse"), t.get("glossy")):
        return None
    lights = t.get("lights", {})
    out = f"{lights.get('count')} lights {str(lights.get('placement')).replace('_', ' ')}"
    if t.get("occlusion") == "shadow_maps":
        out += f" + shadow maps {lights.get('shadow_map_size')}"
    return out


def fits(count: int, size: int) -> bool:
    """Whether `count` shadow maps of `size`^2 texels fit the maps' memory budget."""
    return count * size * size <= MAX_SHADOW_TEXELS
