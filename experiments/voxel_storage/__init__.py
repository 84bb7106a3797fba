"""The voxel storage experiment: one conservative voxel set (voxelize.py) stored as a dense 3D texture
(dense.py), VCT's cascades (cascaded.py), a pointer SVO (octree.py), a Morton-ordered octree
(morton_octree.py, codes in morton.py) and an SVDAG (dag.py); compare.py measures them and decides the
seed's claim, figure.py draws its panels. docs/voxel-storage.md says what is compared and how."""
