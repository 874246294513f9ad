"""Reconstruction: camera lines, surfel mapping (paper III-D) and repeated-scanning voxel maps
(paper III-E)."""
