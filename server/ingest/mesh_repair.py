"""Repairs of authored polygon meshes, each reported once per prim.

Bad input must cost a prim at most its broken faces, never the scene:

- faceVertexIndices outside [0, len(points)) and points that are NaN/Inf:
  the faces using them are skipped (as if they were holes); the arrays are
  made safe to gather from (index 0, point (0, 0, 0)) so that primvar
  expansion and the emitter's finiteness check see only valid data.
- Faces with fewer than 3 vertices produce no triangles.
- Triangles of zero area (repeated or collinear corners, after the
  world transform) are dropped: they carry no surface and their geometric
  normal is undefined (NaN downstream).
- Non-manifold edges (shared by more than two faces) are reported and read
  as they are: surfels sample each face on its own, so they need no
  manifold, but the diagnostic explains odd shading on such meshes.

What cannot be repaired (negative faceVertexCounts, counts that do not sum
to the index count) still raises GeometryError and the prim is skipped by
the caller with an ERROR naming it.
"""
import numpy as np

from chunk_stream import WARNING
from triangle_chunks import GeometryError

# A triangle whose doubled area is below this fraction of its longest edge
# squared is degenerate (collinear to float32 precision: ~1e-7 per
# coordinate, so sound slivers stay far above it).
DEGENERATE_RELATIVE_AREA = 1e-10
# Non-manifold detection sorts every edge: above this many face corners it
# is skipped to keep huge meshes' read time linear.
MAX_CORNERS_FOR_MANIFOLD_CHECK = 4_000_000


class FaceRepair:
    """Result of check_faces: safe arrays and the faces to skip."""

    def __init__(self, points, indices, bad_faces):
        self.points = points        # (P, 3) float64, finite
        self.indices = indices      # (C,) int64, all in [0, P)
        self.bad_faces = bad_faces  # (F,) bool, or None when every face is sound

    @property
    def any_bad(self):
        return self.bad_faces is not None


def check_counts(counts, indices):
    """Raises GeometryError when faces cannot be delimited at all."""
    if counts.size and counts.min() < 0:
        raise GeometryError("negative faceVertexCounts entry")
    total = int(counts.sum())
    if total != len(indices):
        raise GeometryError(
            f"faceVertexCounts sum to {total} but faceVertexIndices has {len(indices)} entries")


def check_faces(path, points, counts, indices, stream):
    """Marks the faces using out-of-range indices or non-finite points and
    reports each kind once. counts must already pass check_counts."""
    point_count = len(points)
    out_of_range = (indices < 0) | (indices >= point_count)
    finite = np.all(np.isfinite(points), axis=1) if point_count else np.zeros(0, dtype=bool)
    safe_indices = np.where(out_of_range, 0, indices) if out_of_range.any() else indices
    bad_point = ~finite
    short = counts < 3
    if not out_of_range.any() and not bad_point.any() and not short.any():
        return FaceRepair(points, indices, None)

    face_of_corner = np.repeat(np.arange(len(counts), dtype=np.int64), counts)
    bad_faces = np.zeros(len(counts), dtype=bool)
    if out_of_range.any():
        faces = np.unique(face_of_corner[out_of_range])
        bad_faces[faces] = True
        stream.diagnostic(WARNING, path, f"{int(out_of_range.sum())} faceVertexIndices outside "
                          f"[0, {point_count}): the {len(faces)} faces using them are skipped",
                          kind="repair-indices")
    if bad_point.any():
        corners = bad_point[safe_indices] & ~out_of_range
        faces = np.unique(face_of_corner[corners])
        bad_faces[faces] = True
        what = f"the {len(faces)} faces using them are skipped" if len(faces) else \
            "no face uses them"
        stream.diagnostic(WARNING, path, f"{int(bad_point.sum())} points are NaN or infinite: "
                          f"{what}", kind="repair-points")
        points = np.where(finite[:, None], points, 0.0)
    if short.any():
        stream.diagnostic(WARNING, path, f"{int(short.sum())} faces have fewer than 3 vertices: "
                          "skipped", kind="repair-short-faces")
    return FaceRepair(points, safe_indices, bad_faces if bad_faces.any() else None)


def degenerate_triangles(world, triangles):
    """(T,) bool: zero-area triangles of world-space points (T, 3) ids.
    Squared quantities, component-wise (np.cross and norms cost 3x more)."""
    a = world[triangles[:, 0]]
    u = world[triangles[:, 1]] - a
    v = world[triangles[:, 2]] - a
    cx = u[:, 1] * v[:, 2] - u[:, 2] * v[:, 1]
    cy = u[:, 2] * v[:, 0] - u[:, 0] * v[:, 2]
    cz = u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0]
    area2_sq = cx * cx + cy * cy + cz * cz
    uu = np.einsum("ij,ij->i", u, u)
    vv = np.einsum("ij,ij->i", v, v)
    w = v - u
    ww = np.einsum("ij,ij->i", w, w)
    longest_sq = np.maximum(np.maximum(uu, vv), ww)
    # |u x v| <= k * longest^2  <=>  |u x v|^2 <= k^2 * longest^4
    return area2_sq <= (DEGENERATE_RELATIVE_AREA ** 2) * longest_sq * longest_sq


def drop_degenerate(path, world, point_triangles, stream):
    """Mask (T,) of triangles to keep; reports how many were dropped."""
    degenerate = degenerate_triangles(world, point_triangles)
    if degenerate.any():
        stream.diagnostic(WARNING, path, f"{int(degenerate.sum())} zero-area or degenerate "
                          "triangles dropped", kind="repair-degenerate")
    return ~degenerate


def report_non_manifold(path, counts, indices, skip_faces, stream):
    """Reports edges shared by more than two faces (read as they are)."""
    if len(indices) == 0 or len(indices) > MAX_CORNERS_FOR_MANIFOLD_CHECK:
        return 0
    starts = np.cumsum(counts) - counts
    sizes = np.repeat(counts, counts)
    corner = np.arange(len(indices), dtype=np.int64)
    following = np.repeat(starts, counts) + (corner - np.repeat(starts, counts) + 1) % \
        np.maximum(sizes, 1)
    keep = np.repeat(counts >= 3, counts)
    if skip_faces is not None:
        keep &= ~np.repeat(skip_faces, counts)
    a, b = indices[keep], indices[following[keep]]
    proper = a != b  # a repeated vertex is no edge
    a, b = a[proper], b[proper]
    lo, hi = np.minimum(a, b), np.maximum(a, b)
    keys = lo * (int(indices.max()) + 1) + hi
    _, uses = np.unique(keys, return_counts=True)
    shared = int((uses > 2).sum())
    if shared:
        stream.diagnostic(WARNING, path, f"non-manifold topology: {shared} edges are shared by "
                          "more than two faces (read as authored)", kind="repair-non-manifold")
    return shared
