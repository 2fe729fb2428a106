"""Mesh and implicit gprims -> world-space triangles (via TriangleEmitter).

Meshes are fan-triangulated as authored. Subdivision surfaces (USD's default
scheme is catmullClark) are sent as their control cage (subdiv_cages.py) and
refined by the daemon; their authored normals are ignored, as USD specifies
for subdivision meshes.

Authored normals (primvars:normals wins over normals) are sent per vertex:
vertex/varying/constant ones per point; faceVarying and uniform ones make
every face corner its own vertex, so that the per-vertex stream stays exact.
The texture coordinates and varying displayColor the mesh's materials read
(mesh_primvars.py) follow the same rule.

Broken polygons are repaired first (mesh_repair.py): faces with out-of-range
indices or NaN/Inf points are skipped, zero-area triangles dropped,
non-manifold edges reported; each repair is one WARNING naming the prim.
"""
import numpy as np
from pxr import UsdGeom

from chunk_stream import WARNING
from implicit_shapes import tessellate
from mesh_primvars import expand, material_primvars, needs_unweld
from mesh_repair import check_counts, check_faces, drop_degenerate, report_non_manifold
from subdiv_cages import SCHEMES, cage_chunk
from triangle_chunks import fan_triangulate, mirrors, transform_normals, transform_points


def _authored_normals(mesh, time, point_count, corner_count, face_count, stream):
    """(values (N, 3) float64, interpolation) or (None, None)."""
    primvar = UsdGeom.PrimvarsAPI(mesh.GetPrim()).GetPrimvar("normals")
    if primvar and primvar.HasAuthoredValue():
        values, interpolation = primvar.ComputeFlattened(time), primvar.GetInterpolation()
    elif mesh.GetNormalsAttr().HasAuthoredValue():
        values, interpolation = mesh.GetNormalsAttr().Get(time), mesh.GetNormalsInterpolation()
    else:
        return None, None
    if values is None or len(values) == 0:
        return None, None
    expected = {UsdGeom.Tokens.vertex: point_count, UsdGeom.Tokens.varying: point_count,
                UsdGeom.Tokens.faceVarying: corner_count, UsdGeom.Tokens.uniform: face_count,
                UsdGeom.Tokens.constant: 1}.get(interpolation)
    path = str(mesh.GetPath())
    if expected is None or len(values) != expected:
        stream.diagnostic(WARNING, path, f"{len(values)} {interpolation} normals where "
                          f"{expected} are expected: using geometric normals", kind="normals")
        return None, None
    return np.asarray(values, dtype=np.float64).reshape(-1, 3), interpolation


def read_mesh(prim, matrix, time, materials, emitter, stream):
    """Emits the mesh's triangles; returns how many. Raises GeometryError."""
    mesh = UsdGeom.Mesh(prim)
    path = str(prim.GetPath())
    points = mesh.GetPointsAttr().Get(time)
    counts = mesh.GetFaceVertexCountsAttr().Get(time)
    indices = mesh.GetFaceVertexIndicesAttr().Get(time)
    if points is None or counts is None or indices is None or len(counts) == 0:
        return 0
    points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    counts = np.asarray(counts, dtype=np.int64)
    indices = np.asarray(indices, dtype=np.int64)
    # Broken faces (out-of-range indices, NaN/Inf points) are skipped and
    # the arrays made safe to gather from (mesh_repair.py).
    check_counts(counts, indices)
    repair = check_faces(path, points, counts, indices, stream)
    points, indices = repair.points, repair.indices

    scheme = mesh.GetSubdivisionSchemeAttr().Get(time)
    subdivided = scheme != UsdGeom.Tokens.none
    if subdivided and scheme not in SCHEMES:
        stream.diagnostic(WARNING, path, f"unknown subdivisionScheme '{scheme}': triangulated as "
                          "its control cage", kind="subdivision")
    left_handed = mesh.GetOrientationAttr().Get(time) == UsdGeom.Tokens.leftHanded
    material = materials.for_prim(prim)
    per_face = materials.subset_materials(prim, len(counts), material)
    double_sided = bool(mesh.GetDoubleSidedAttr().Get(time))
    if scheme in SCHEMES and repair.any_bad:
        stream.diagnostic(WARNING, path, "subdivision cage with skipped faces: read as its "
                          "repaired control cage, not refined", kind="subdivision")
    elif scheme in SCHEMES:
        report_non_manifold(path, counts, indices, None, stream)
        chunk = cage_chunk(mesh, scheme, transform_points(points, matrix), counts, indices,
                           left_handed != mirrors(matrix), material, per_face, double_sided,
                           time, stream)
        if chunk is not None:
            stream.write(chunk)
            return 0
    holes = mesh.GetHoleIndicesAttr().Get(time)
    if repair.any_bad:
        holes = np.concatenate([np.asarray(holes if holes is not None else [], dtype=np.int64),
                                np.flatnonzero(repair.bad_faces)])
    corners, faces = fan_triangulate(counts, indices, left_handed != mirrors(matrix), holes)
    if len(corners) == 0:
        return 0

    world = transform_points(points, matrix)
    keep = drop_degenerate(path, world, indices[corners], stream)
    if not keep.all():
        corners, faces = corners[keep], faces[keep]
        if len(corners) == 0:
            return 0
    # Faces left without triangles (skipped, holes, degenerate) are not
    # part of the surface whose topology is checked.
    unused_faces = np.ones(len(counts), dtype=bool)
    unused_faces[faces] = False
    report_non_manifold(path, counts, indices, unused_faces, stream)
    normals, interpolation = (None, None) if subdivided else _authored_normals(
        mesh, time, len(points), len(indices), len(counts), stream)
    extras = material_primvars(mesh, time, materials, per_face if per_face is not None else material,
                               counts, indices, len(points), stream)
    unweld = needs_unweld(interpolation) or any(needs_unweld(i) for _, i in extras.values())
    positions, triangles = (world[indices], corners) if unweld else (world, indices[corners])
    extras = {name: expand(values, i, counts, indices, len(points), unweld)
              for name, (values, i) in extras.items()}
    if normals is not None:
        normals = transform_normals(expand(normals, interpolation, counts, indices, len(points),
                                           unweld), matrix)
        if not np.all(np.isfinite(normals)) or np.any(np.abs(normals).sum(axis=1) == 0.0):
            stream.diagnostic(WARNING, path, "zero or non-finite normals: using geometric normals",
                              kind="normals")
            normals = None
            if not extras:
                positions, triangles = world, indices[corners]

    triangle_materials = per_face[faces] if per_face is not None else material
    return emitter.emit(path, positions, normals, triangles, triangle_materials, double_sided,
                        uvs=extras.get("uvs"), colors=extras.get("colors"))


def read_implicit(prim, matrix, time, materials, emitter, stream):
    """Tessellates Sphere/Cube/Cylinder/Cone/Capsule/Plane; returns triangles."""
    points, triangles, normals = tessellate(prim, time)
    if mirrors(matrix):
        triangles = triangles[:, [0, 2, 1]]
    double_sided = bool(UsdGeom.Gprim(prim).GetDoubleSidedAttr().Get(time))
    return emitter.emit(str(prim.GetPath()), transform_points(points, matrix),
                        transform_normals(normals, matrix), triangles,
                        materials.for_prim(prim), double_sided)
