"""iblcheck's shared scene model (pure numpy): scenes, environments, meshes, camera, tone mapping.

Both renderers import from here and never from each other, so the conventions they must agree
on (axes, rows, fov axis, cube faces, the env-map pixel convention) live in exactly one place.
"""

from scenes.model.scene import EFFECTS, Scene, builtin_names, load
from scenes.storage.errors import EnvMapError, InputError, MeshError, MissingCapability, SceneError

__all__ = ["EFFECTS", "EnvMapError", "InputError", "MeshError", "MissingCapability", "Scene",
           "SceneError", "builtin_names", "load"]
