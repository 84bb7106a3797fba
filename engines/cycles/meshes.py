"""The export's meshes as Blender meshes: the exported float32 positions and normals, exactly.

Built from the arrays directly (never Blender's glTF importer): positions and normals go through the exact
axis change (axes.to_blender), the normals into the free `custom_normal` attribute on the POINT domain
(Blender 4.5+), so Cycles interpolates the exported vertex normals themselves. Blender's other custom-normal
path (`normals_split_custom_set_from_vertices`) stores them as 16-bit angles in each corner's normal space,
off by up to ~4e-5; a test reads the normals back.
"""

from __future__ import annotations

import numpy as np

from engines.cycles import axes
from engines.cycles.exported import Object


def build(bpy, obj: Object, name: str, material):
    """A Blender mesh object of `obj` with `material`, linked into the scene."""
    positions = axes.to_blender(obj.positions).astype(np.float32)
    normals = axes.to_blender(obj.normals).astype(np.float32)
    mesh = bpy.data.meshes.new(name)
    mesh.vertices.add(len(positions))
    mesh.vertices.foreach_set("co", positions.ravel())
    corners = obj.indices.astype(np.int32).ravel()
    mesh.loops.add(len(corners))
    mesh.loops.foreach_set("vertex_index", corners)
    n_faces = len(obj.indices)
    mesh.polygons.add(n_faces)
    mesh.polygons.foreach_set("loop_start", np.arange(0, 3 * n_faces, 3, dtype=np.int32))
    mesh.polygons.foreach_set("loop_total", np.full(n_faces, 3, dtype=np.int32))
    mesh.polygons.foreach_set("use_smooth", np.ones(n_faces, dtype=bool))
    mesh.update(calc_edges=True)  # the edges Blender's mesh needs (Cycles renders nothing without them)
    custom = mesh.attributes.new("custom_normal", "FLOAT_VECTOR", "POINT")
    custom.data.foreach_set("vector", normals.ravel())
    mesh.update()
    mesh.materials.append(material)
    ob = bpy.data.objects.new(name, mesh)
    # Cycles' shadow-terminator offsets move shadow-ray origins off low-poly smooth meshes; Mitsuba does not
    ob.shadow_terminator_geometry_offset = 0.0
    ob.shadow_terminator_normal_offset = 0.0
    ob.shadow_terminator_shading_offset = 0.0
    bpy.context.scene.collection.objects.link(ob)
    return ob


def read_back(bpy, ob) -> tuple[np.ndarray, np.ndarray]:
    """(positions, vertex normals) of a built object as Blender holds them, in Blender axes (for tests)."""
    mesh = ob.data
    co = np.zeros(3 * len(mesh.vertices), dtype=np.float32)
    mesh.vertices.foreach_get("co", co)
    nv = np.zeros(3 * len(mesh.vertices), dtype=np.float32)
    mesh.vertex_normals.foreach_get("vector", nv)
    return co.reshape(-1, 3), nv.reshape(-1, 3)
