"""Subdivision meshes -> SubdivCage chunks (proto/pbgi/v1/scene.proto).

A UsdGeomMesh whose subdivisionScheme is catmullClark (USD's fallback), loop
or bilinear is sent as its control cage with USD's subdivision tags; the
daemon refines it with OpenSubdiv (server/ingest/subdivision.h), mesh by
mesh while decoding. The cage goes in world space (subdivision is
affine-invariant, so refining the transformed cage equals transforming the
refined surface, and the daemon's target edge length is in world units);
faces are re-wound so that they are counter-clockwise around the outward
world-space normal (orientation = leftHanded and mirroring transforms).

Cages the daemon cannot refine fall back to their triangulated cage with a
diagnostic naming the prim: Loop meshes with non-triangles (ERROR: USD
requires triangles for Loop), faces with fewer than 3 vertices, and cages too
large for one stream frame.
"""
import numpy as np
from pxr import Usd, UsdGeom

from chunk_stream import ERROR, WARNING
from pbgi.v1 import scene_pb2
from triangle_chunks import GeometryError, transform_points

SCHEMES = {
    UsdGeom.Tokens.catmullClark: scene_pb2.SubdivCage.CATMULL_CLARK,
    UsdGeom.Tokens.loop: scene_pb2.SubdivCage.LOOP,
    UsdGeom.Tokens.bilinear: scene_pb2.SubdivCage.BILINEAR,
}
_BOUNDARY = {
    UsdGeom.Tokens.none: scene_pb2.SubdivCage.BOUNDARY_NONE,
    UsdGeom.Tokens.edgeOnly: scene_pb2.SubdivCage.EDGE_ONLY,
    UsdGeom.Tokens.edgeAndCorner: scene_pb2.SubdivCage.EDGE_AND_CORNER,
}
_FACE_VARYING = {
    UsdGeom.Tokens.none: scene_pb2.SubdivCage.FVAR_NONE,
    UsdGeom.Tokens.cornersOnly: scene_pb2.SubdivCage.CORNERS_ONLY,
    UsdGeom.Tokens.cornersPlus1: scene_pb2.SubdivCage.CORNERS_PLUS1,
    UsdGeom.Tokens.cornersPlus2: scene_pb2.SubdivCage.CORNERS_PLUS2,
    UsdGeom.Tokens.boundaries: scene_pb2.SubdivCage.BOUNDARIES,
    UsdGeom.Tokens.all: scene_pb2.SubdivCage.ALL,
}
_TRIANGLE_RULE = {
    UsdGeom.Tokens.catmullClark: scene_pb2.SubdivCage.TRIANGLE_CATMULL_CLARK,
    UsdGeom.Tokens.smooth: scene_pb2.SubdivCage.TRIANGLE_SMOOTH,
}
# The daemon refuses frames above 256 MiB (scene_stream_decoder.h); a cage
# this large is read as triangles instead.
_MAX_CAGE_BYTES = 192 << 20


def _array(attr, time, dtype):
    values = attr.Get(time)
    return np.zeros(0, dtype=dtype) if values is None else np.asarray(values, dtype=dtype).reshape(-1)


def _token(mesh, attr, time, table, fallback, stream, name):
    value = attr.Get(time)
    if value in table:
        return table[value]
    if value is not None:
        stream.diagnostic(WARNING, str(mesh.GetPath()), f"unknown {name} '{value}': using "
                          "USD's fallback", kind=f"subdivision-{name}")
    return fallback


def _tags(mesh, time, point_count, face_count, stream):
    """Crease, corner and hole arrays as packed bytes. An inconsistent group
    is dropped with a WARNING naming the prim (the daemon would reject the
    whole stream), so the surface is still refined, only without it."""
    path = str(mesh.GetPath())

    def dropped(what, why):
        stream.diagnostic(WARNING, path, f"{what} ignored: {why}", kind=f"subdivision-{what}")

    c_idx = _array(mesh.GetCreaseIndicesAttr(), time, np.int64)
    c_len = _array(mesh.GetCreaseLengthsAttr(), time, np.int64)
    c_sharp = _array(mesh.GetCreaseSharpnessesAttr(), time, np.float64)
    edges = int((c_len - 1).sum()) if len(c_len) else 0
    problem = None
    if len(c_len) and c_len.min() < 2:
        problem = "a creaseLengths entry is below 2"
    elif int(c_len.sum()) != len(c_idx):
        problem = f"creaseLengths sum to {int(c_len.sum())} but creaseIndices has {len(c_idx)}"
    elif len(c_sharp) not in (len(c_len), edges):
        problem = f"{len(c_sharp)} creaseSharpnesses for {len(c_len)} creases of {edges} edges"
    elif len(c_idx) and (c_idx.min() < 0 or c_idx.max() >= point_count):
        problem = "creaseIndices out of range"
    elif not np.all(np.isfinite(c_sharp)):
        problem = "non-finite creaseSharpnesses"
    if problem:
        dropped("creases", problem)
        c_idx, c_len, c_sharp = (np.zeros(0),) * 3

    k_idx = _array(mesh.GetCornerIndicesAttr(), time, np.int64)
    k_sharp = _array(mesh.GetCornerSharpnessesAttr(), time, np.float64)
    problem = None
    if len(k_idx) != len(k_sharp):
        problem = f"{len(k_idx)} cornerIndices but {len(k_sharp)} cornerSharpnesses"
    elif len(k_idx) and (k_idx.min() < 0 or k_idx.max() >= point_count):
        problem = "cornerIndices out of range"
    elif not np.all(np.isfinite(k_sharp)):
        problem = "non-finite cornerSharpnesses"
    if problem:
        dropped("corners", problem)
        k_idx, k_sharp = np.zeros(0), np.zeros(0)

    holes = _array(mesh.GetHoleIndicesAttr(), time, np.int64)
    holes = holes[(holes >= 0) & (holes < face_count)]  # as the cage triangulation does

    def u32(a):
        return np.asarray(a, dtype="<u4").tobytes()

    def f32(a):
        return np.asarray(a, dtype="<f4").tobytes()

    return (u32(c_idx), u32(c_len), f32(c_sharp)), (u32(k_idx), f32(k_sharp)), u32(holes)


def reverse_faces(counts, indices):
    """Reverses every face's winding, keeping its first vertex:
    [a, b, c, d] -> [a, d, c, b] (face ids, edges and creases unchanged)."""
    starts = np.repeat(np.cumsum(counts) - counts, counts)
    sizes = np.repeat(counts, counts)
    j = np.arange(len(indices), dtype=np.int64) - starts
    return indices[starts + (sizes - j) % sizes]


def cage_chunk(mesh, scheme, world_points, counts, indices, flip, material, face_materials,
               double_sided, time, stream):
    """The SceneChunk carrying the cage, or None (after a diagnostic naming
    the prim) if it must be read as its triangulated cage instead. Raises
    GeometryError for inconsistent faces."""
    path = str(mesh.GetPath())
    if counts.size and counts.min() < 0:
        raise GeometryError("negative faceVertexCounts entry")
    if int(counts.sum()) != len(indices):
        raise GeometryError(f"faceVertexCounts sum to {int(counts.sum())} but faceVertexIndices "
                            f"has {len(indices)} entries")
    if counts.size and counts.min() < 3:
        stream.diagnostic(WARNING, path, f"subdivisionScheme '{scheme}' with faces of fewer than "
                          "3 vertices cannot be refined: triangulated as its control cage",
                          kind="subdivision")
        return None
    if scheme == UsdGeom.Tokens.loop and counts.size and counts.max() != 3:
        face = int(np.flatnonzero(counts != 3)[0])
        stream.diagnostic(ERROR, path, f"subdivisionScheme 'loop' needs triangles, but face {face} "
                          f"has {int(counts[face])} vertices: triangulated as its control cage "
                          "instead of refined", kind="subdivision")
        return None
    size = 12 * len(world_points) + 8 * len(counts) + 4 * len(indices)
    if size > _MAX_CAGE_BYTES:
        stream.diagnostic(WARNING, path, f"subdivision cage of {len(counts)} faces is too large to "
                          "refine: triangulated as its control cage", kind="subdivision")
        return None

    chunk = scene_pb2.SceneChunk()
    cage = chunk.subdiv_cage
    cage.prim_path = path
    cage.material_id = int(material)
    cage.double_sided = bool(double_sided)
    cage.scheme = SCHEMES[scheme]
    cage.positions = np.ascontiguousarray(world_points, dtype="<f4").tobytes()
    cage.face_vertex_counts = counts.astype("<u4").tobytes()
    wound = reverse_faces(counts, indices) if flip else indices
    cage.face_vertex_indices = wound.astype("<u4").tobytes()
    if face_materials is not None:
        cage.face_material_ids = np.asarray(face_materials, dtype="<u4").tobytes()
    creases, corners, holes = _tags(mesh, time, len(world_points), len(counts), stream)
    cage.crease_indices, cage.crease_lengths, cage.crease_sharpnesses = creases
    cage.corner_indices, cage.corner_sharpnesses = corners
    cage.hole_indices = holes
    cage.interpolate_boundary = _token(mesh, mesh.GetInterpolateBoundaryAttr(), time, _BOUNDARY,
                                       scene_pb2.SubdivCage.EDGE_AND_CORNER, stream,
                                       "interpolateBoundary")
    cage.face_varying_linear_interpolation = _token(
        mesh, mesh.GetFaceVaryingLinearInterpolationAttr(), time, _FACE_VARYING,
        scene_pb2.SubdivCage.CORNERS_PLUS1, stream, "faceVaryingLinearInterpolation")
    cage.triangle_subdivision_rule = _token(
        mesh, mesh.GetTriangleSubdivisionRuleAttr(), time, _TRIANGLE_RULE,
        scene_pb2.SubdivCage.TRIANGLE_CATMULL_CLARK, stream, "triangleSubdivisionRule")
    return chunk


def polygon_areas(points, counts, indices):
    """Area of every face (Newell: half the length of the sum of its edges'
    cross products), for planar and non-planar polygons alike."""
    if len(counts) == 0:
        return np.zeros(0)
    starts = np.cumsum(counts) - counts
    following = np.arange(1, len(indices) + 1, dtype=np.int64)
    following[starts + counts - 1] = starts  # each face's last corner wraps to its first
    cross = np.cross(points[indices], points[indices[following]])
    return 0.5 * np.linalg.norm(np.add.reduceat(cross, starts, axis=0), axis=1)


def total_cage_area(stage, time, xforms, visible):
    """The summed world-space area of the subdivision cages the traversal
    will send (both faces of double-sided ones, as the surfel sampler counts
    them; every native instance once), for SceneHeader.subdiv_cage_area: the
    daemon derives from it the surfel spacing each cage's refinement error
    is bounded by, before the cages arrive. `visible(prim)` is the
    traversal's pruning test. PointInstancer prototypes, polygon meshes and
    implicit shapes are left out (a smaller area only makes the bound
    stricter), and so are hole faces. Cages whose arrays are unusable count 0."""
    predicate = Usd.TraverseInstanceProxies(Usd.PrimDefaultPredicate)
    prims = iter(Usd.PrimRange(stage.GetPseudoRoot(), predicate))
    total = 0.0
    for prim in prims:
        if prim.IsA(UsdGeom.PointInstancer) or not visible(prim):
            prims.PruneChildren()
            continue
        if not prim.IsA(UsdGeom.Mesh):
            continue
        mesh = UsdGeom.Mesh(prim)
        if mesh.GetSubdivisionSchemeAttr().Get(time) not in SCHEMES:
            continue
        points = mesh.GetPointsAttr().Get(time)
        counts = mesh.GetFaceVertexCountsAttr().Get(time)
        indices = mesh.GetFaceVertexIndicesAttr().Get(time)
        if points is None or counts is None or indices is None:
            continue
        points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        counts = np.asarray(counts, dtype=np.int64)
        indices = np.asarray(indices, dtype=np.int64)
        if len(counts) == 0 or counts.min() < 1 or int(counts.sum()) != len(indices) or \
                (len(indices) and (indices.min() < 0 or indices.max() >= len(points))):
            continue
        world = transform_points(points, xforms.GetLocalToWorldTransform(prim))
        areas = polygon_areas(world, counts, indices)
        holes = _array(mesh.GetHoleIndicesAttr(), time, np.int64)
        areas[holes[(holes >= 0) & (holes < len(counts))]] = 0.0
        area = float(np.nansum(areas))
        if not np.isfinite(area):
            continue
        total += area * (2.0 if mesh.GetDoubleSidedAttr().Get(time) else 1.0)
    return total
