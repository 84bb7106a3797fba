"""The environment: the export's .hdr as Blender's world, rotated as the sidecar says.

Texture Coordinate (Generated: the world ray's direction D) -> Mapping (POINT, Euler Z = -theta,
axes.mapping_rotation) -> Environment Texture (equirectangular, linear interpolation, the image in
'Linear Rec.709', i.e. the radiance as stored) -> Background of strength `intensity`. Blender's equirect in
its axes is the viewers' convention in glTF's (axes.py), so radiance from world d is the map's at
R_y(-theta) d. Importance sampling of the map: Cycles' automatic map resolution, MIS with the BSDF.
"""

from __future__ import annotations

from pathlib import Path

from engines.cycles import axes
from engines.cycles.errors import SceneRejected


def build(bpy, environment: Path, rotation_y_deg: float, intensity: float):
    try:
        image = bpy.data.images.load(str(environment), check_existing=False)
        image.colorspace_settings.name = "Linear Rec.709"
        size = tuple(image.size)
    except RuntimeError as exc:
        raise SceneRejected(f"{environment}: Blender cannot read the environment map ({exc})") from None
    if min(size) < 1:
        raise SceneRejected(f"{environment}: Blender reads the environment map as {size[0]} x {size[1]} pixels")
    world = bpy.data.worlds.new("environment")
    nodes, links = world.node_tree.nodes, world.node_tree.links
    nodes.clear()
    coords = nodes.new("ShaderNodeTexCoord")
    mapping = nodes.new("ShaderNodeMapping")
    mapping.vector_type = "POINT"
    mapping.inputs["Rotation"].default_value = axes.mapping_rotation(rotation_y_deg)
    texture = nodes.new("ShaderNodeTexEnvironment")
    texture.image = image
    texture.projection = "EQUIRECTANGULAR"
    texture.interpolation = "Linear"
    background = nodes.new("ShaderNodeBackground")
    background.inputs["Strength"].default_value = float(intensity)
    out = nodes.new("ShaderNodeOutputWorld")
    links.new(coords.outputs["Generated"], mapping.inputs["Vector"])
    links.new(mapping.outputs["Vector"], texture.inputs["Vector"])
    links.new(texture.outputs["Color"], background.inputs["Color"])
    links.new(background.outputs["Background"], out.inputs["Surface"])
    bpy.context.scene.world = world
    return world
