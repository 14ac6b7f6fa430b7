"""Live 3D from the robots' own sensors (issue #33), without I/O: clouds and depth decoded, fused into voxel blocks."""
