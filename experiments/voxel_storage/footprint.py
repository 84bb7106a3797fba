"""What one storage structure costs for one voxel set: the record every structure's `footprint` returns.

The payload of a voxel is iblcheck's VCT texel (realtime/techniques/vct/vct.py): six faces (+X, -X, +Y,
-Y, +Z, -Z), each RGBA16F, 6 x 4 x 2 = 48 bytes (iblcheck's VCT also keeps a column texture of 8 more bytes a
voxel for its opacity reads; the seed's structures store the radiance faces alone, so it is left out). No
structure here counts mip levels (a dense grid's mip chain would add 1/7, a sparse octree's inner nodes would
need their own filtered payload): every structure stores the finest level only, so they compare alike.
"""

from __future__ import annotations

from dataclasses import dataclass

#: bytes of one voxel's payload: six RGBA16F faces
PAYLOAD_BYTES = 6 * 4 * 2
#: bytes of one voxel in a 1-byte occupancy grid
OCCUPANCY_BYTES = 1


@dataclass(frozen=True)
class Footprint:
    structure: str
    cells: int  # voxels (or leaves) the structure stores, occupied or not
    occupied: int  # of those, the set ones
    nodes: int  # inner nodes (0 for a grid or a code list)
    bytes: int  # with the 48-byte payload per stored voxel
    bytes_geometry: int  # without payload (occupancy or structure only)
    finest_voxel: float  # edge of its finest voxel (world units)
    covered: float  # fraction of the scene's finest-voxel set it stores at that finest voxel size
    nodes_per_level: tuple[int, ...] = ()  # octree nodes per level (root first); cascades: set voxels per cascade
