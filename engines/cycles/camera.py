"""The sidecar's camera as a Blender camera: the same pixel rays as iblcheck's.

Blender's camera looks down local -Z with +Y up (axes.camera_to_world). sensor_fit VERTICAL makes the
field of view act on the image height, and angle = yfov then sets the lens to
sensor_height / (2 tan(yfov / 2)): the vertical fov of iblcheck (Mitsuba `fov_axis = 'y'`); square pixels.
No shift, no depth of field. Clipping: 1e-3 to 1e6 as the Mitsuba reference's.
"""

from __future__ import annotations

import math

from engines.cycles import axes
from engines.cycles.exported import View


def build(bpy, view: View):
    import mathutils  # deferred: Blender's math module, present only beside bpy

    data = bpy.data.cameras.new("camera")
    data.type = "PERSP"
    data.sensor_fit = "VERTICAL"
    data.angle_y = math.radians(view.yfov_deg)
    data.shift_x = data.shift_y = 0.0
    data.clip_start, data.clip_end = 1e-3, 1e6
    data.dof.use_dof = False
    ob = bpy.data.objects.new("camera", data)
    # mathutils.Matrix takes rows; a nested list assigned to matrix_world directly is read as columns
    ob.matrix_world = mathutils.Matrix(axes.camera_to_world(view.position, view.target, view.up).tolist())
    scene = bpy.context.scene
    scene.collection.objects.link(ob)
    scene.camera = ob
    return ob
