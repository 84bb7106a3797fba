"""Blender's Cycles as a second, independent path tracer (bpy, the `engines` extra).

    python -m engines.cycles.render --sidecar FILE --output FILE.exr [--timings FILE.json] [--spp N --seed S]

renders the files `iblcheck export` writes (scenes/exchange/) to a linear float32 OpenEXR. The pure-numpy
parts (reading the export, the axis change, the material choice) import without bpy; only
`render.main` imports it, and passes the module to the builders (camera.py, world.py, materials.py,
meshes.py, settings.py).
"""
