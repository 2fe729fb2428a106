"""Mesh primvars the materials need, per vertex of the emitted triangles.

Two are sent with MeshChunks: the texture coordinates a material's
UsdUVTexture reads (the UsdPrimvarReader_float2 varname, usually "st") and
primvars:displayColor where it varies over the mesh. Like authored
normals, vertex/varying values stay per point; faceVarying and uniform ones
(of any of them) make every face corner its own vertex; constant ones are
repeated.
"""
import numpy as np
from pxr import UsdGeom

from chunk_stream import WARNING

_UNWELDING = (UsdGeom.Tokens.faceVarying, UsdGeom.Tokens.uniform)


def needs_unweld(interpolation):
    return interpolation in _UNWELDING


def expected_count(interpolation, point_count, corner_count, face_count):
    return {UsdGeom.Tokens.vertex: point_count, UsdGeom.Tokens.varying: point_count,
            UsdGeom.Tokens.faceVarying: corner_count, UsdGeom.Tokens.uniform: face_count,
            UsdGeom.Tokens.constant: 1}.get(interpolation)


def expand(values, interpolation, counts, indices, point_count, unweld):
    """Values per point (unweld False) or per face corner (unweld True)."""
    if unweld:
        if interpolation in (UsdGeom.Tokens.vertex, UsdGeom.Tokens.varying):
            return values[indices]
        if interpolation == UsdGeom.Tokens.uniform:
            return np.repeat(values, counts, axis=0)
        if interpolation == UsdGeom.Tokens.constant:
            return np.repeat(values, len(indices), axis=0)
        return values  # faceVarying
    if interpolation == UsdGeom.Tokens.constant:
        return np.repeat(values, point_count, axis=0)
    return values


def _read(mesh, name, width, time, counts, indices, point_count, stream, purpose):
    """(values (N, width) float64, interpolation) of primvars:<name>, or
    (None, None) after one WARNING if it is missing or malformed."""
    path = str(mesh.GetPath())
    primvar = UsdGeom.PrimvarsAPI(mesh.GetPrim()).GetPrimvar(name)
    values = primvar.ComputeFlattened(time) if primvar and primvar.HasValue() else None
    if values is None or len(values) == 0:
        stream.diagnostic(WARNING, path, f"{purpose} reads primvar '{name}', which the mesh does "
                          "not have: using the texture's mean", kind=f"primvar-missing:{name}")
        return None, None
    interpolation = primvar.GetInterpolation()
    values = np.asarray(values, dtype=np.float64)
    expected = expected_count(interpolation, point_count, len(indices), len(counts))
    if values.ndim != 2 or values.shape[1] != width or expected is None or len(values) != expected:
        stream.diagnostic(WARNING, path, f"primvar '{name}': {len(values)} {interpolation} values "
                          f"where {expected} of {width} components are expected: ignored",
                          kind=f"primvar-shape:{name}")
        return None, None
    return values, interpolation


def material_primvars(mesh, time, materials, material_ids, counts, indices, point_count, stream):
    """{"uvs": (values, interpolation), "colors": (...)} for what the mesh's
    materials (material_ids: one id or one per face) need."""
    out = {}
    path = str(mesh.GetPath())
    names = materials.uv_primvars(material_ids)
    if names:
        if len(names) > 1:
            stream.diagnostic(WARNING, path, f"materials read texture coordinates from primvars "
                              f"{', '.join(names)}; only '{names[0]}' is sent", kind="uv-sets")
        values, interpolation = _read(mesh, names[0], 2, time, counts, indices, point_count,
                                      stream, "a texture")
        if values is not None:
            out["uvs"] = (values, interpolation)
    if materials.wants_vertex_colors(material_ids):
        values, interpolation = _read(mesh, "displayColor", 3, time, counts, indices,
                                      point_count, stream, "diffuseColor")
        if values is not None:
            out["colors"] = (values, interpolation)
    return out
