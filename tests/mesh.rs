//! Mesh loading, procedural meshes, voxel-sphere colliders and accuracy metrics (CPU).
