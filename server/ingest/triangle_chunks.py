"""Triangles of one prim -> world-space MeshChunk messages.

All array work is vectorized with numpy so that meshes with millions of faces
cost a handful of array passes, not a Python loop per face.
"""
import numpy as np

from pbgi.v1 import scene_pb2


class GeometryError(ValueError):
    """The prim's geometry is inconsistent (message names what is wrong)."""


def fan_triangulate(counts, indices, left_handed, holes=None):
    """Fan-triangulates polygons of any size.

    Returns (corners, faces): corners is (T, 3) int64 indices into the
    face-vertex list (so that face-varying data can be looked up), faces is
    (T,) the polygon each triangle came from. Polygons with fewer than three
    vertices and hole faces produce no triangles. Winding follows the
    polygon's; leftHanded meshes are flipped so that every triangle is
    counter-clockwise around its right-handed normal.
    """
    counts = np.asarray(counts, dtype=np.int64)
    if counts.size and counts.min() < 0:
        raise GeometryError("negative faceVertexCounts entry")
    total = int(counts.sum())
    if total != len(indices):
        raise GeometryError(
            f"faceVertexCounts sum to {total} but faceVertexIndices has {len(indices)} entries")
    starts = np.cumsum(counts) - counts
    per_face = np.where(counts >= 3, counts - 2, 0)
    if holes is not None and len(holes):
        holes = np.asarray(holes, dtype=np.int64)
        holes = holes[(holes >= 0) & (holes < counts.size)]
        per_face[holes] = 0
    triangle_count = int(per_face.sum())
    faces = np.repeat(np.arange(counts.size, dtype=np.int64), per_face)
    first_triangle = np.cumsum(per_face) - per_face
    k = np.arange(triangle_count, dtype=np.int64) - np.repeat(first_triangle, per_face)
    base = starts[faces]
    corners = np.empty((triangle_count, 3), dtype=np.int64)
    corners[:, 0] = base
    corners[:, 1] = base + k + 1
    corners[:, 2] = base + k + 2
    if left_handed:
        corners[:, [1, 2]] = corners[:, [2, 1]]
    return corners, faces


def transform_points(points, matrix):
    """Row-vector convention of USD: p' = [p, 1] * M."""
    m = np.asarray(matrix, dtype=np.float64)
    return points @ m[:3, :3] + m[3, :3]


def transform_normals(normals, matrix):
    """Normals go by the inverse transpose of the linear part, then unit length."""
    m = np.asarray(matrix, dtype=np.float64)[:3, :3]
    n = normals @ np.linalg.inv(m).T
    length = np.linalg.norm(n, axis=1, keepdims=True)
    return n / np.where(length > 0.0, length, 1.0)


def mirrors(matrix):
    """True if the transform flips handedness (so winding must flip too)."""
    return np.linalg.det(np.asarray(matrix, dtype=np.float64)[:3, :3]) < 0.0


class TriangleEmitter:
    """Splits a prim's triangles by material and size into MeshChunks."""

    def __init__(self, stream, max_triangles_per_chunk):
        if max_triangles_per_chunk < 1:
            raise ValueError("max triangles per chunk must be >= 1")
        self._stream = stream
        self._max = int(max_triangles_per_chunk)

    def emit(self, prim_path, positions, normals, triangles, materials, double_sided, uvs=None,
             colors=None):
        """positions (V, 3) world space, normals (V, 3) or None, triangles
        (T, 3) vertex ids, materials (T,) material ids or a single id; uvs
        (V, 2) and colors (V, 3) per vertex, or None."""
        if len(triangles) == 0:
            return 0
        if not np.all(np.isfinite(positions)):
            raise GeometryError("non-finite point positions")
        positions = np.ascontiguousarray(positions, dtype=np.float32)
        if normals is not None:
            normals = np.ascontiguousarray(normals, dtype=np.float32)
        extras = {name: np.ascontiguousarray(values, dtype=np.float32)
                  for name, values in (("uvs", uvs), ("colors", colors)) if values is not None}
        materials = np.asarray(materials, dtype=np.int64)
        # Scratch for re-indexing: vertex -> index in the current chunk, -1
        # elsewhere; each chunk resets only the entries it touched.
        remap = np.full(len(positions), -1, dtype=np.int64)
        groups = [(int(materials), triangles)] if materials.ndim == 0 else \
            [(int(m), triangles[materials == m]) for m in np.unique(materials)]
        for material, group in groups:
            for begin in range(0, len(group), self._max):
                self._emit_chunk(prim_path, positions, normals, group[begin:begin + self._max],
                                 material, double_sided, remap, extras)
        return len(triangles)

    def _emit_chunk(self, prim_path, positions, normals, triangles, material, double_sided, remap,
                    extras=None):
        # Each chunk carries only the vertices it uses, re-indexed from 0.
        # Small meshes: mark and scan (O(vertices)); a chunk of a much larger
        # mesh: sort its indices instead, so the cost stays O(chunk).
        flat = triangles.reshape(-1)
        if len(positions) <= 8 * len(flat):
            remap[flat] = 0
            used = np.flatnonzero(remap == 0)
        else:
            used = np.unique(flat)
        remap[used] = np.arange(len(used))
        local = remap[flat]
        remap[used] = -1
        chunk = scene_pb2.SceneChunk()
        mesh = chunk.mesh
        mesh.prim_path = prim_path
        mesh.material_id = material
        mesh.double_sided = bool(double_sided)
        mesh.positions = positions[used].astype("<f4", copy=False).tobytes()
        if normals is not None:
            mesh.normals = normals[used].astype("<f4", copy=False).tobytes()
        for name, values in (extras or {}).items():
            setattr(mesh, name, values[used].astype("<f4", copy=False).tobytes())
        mesh.indices = local.astype("<u4").tobytes()
        self._stream.triangle_count += len(triangles)
        self._stream.write(chunk)
