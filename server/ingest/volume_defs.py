"""UsdVol.Volume -> VolumeDef (proto/pbgi/v1/scene.proto).

Each `field:<name>` relationship of the volume that targets an OpenVDBAsset
becomes a VolumeField: the resolved .vdb file (filePath at the frame's
time), the grid's name (fieldName) or fieldIndex, and the field prim's own
local-to-world transform (fields are Xformable; usually children of the
volume, so this includes the volume's). The daemon opens the grids
(server/volumes): level sets become surfaces, fog grids volume data.
Fields of other kinds (Field3DAsset, ...) and unresolvable files are
reported once per prim and skipped.
"""
from pxr import UsdVol

from asset_roots import unresolved_location
from chunk_stream import WARNING
from light_defs import matrix_floats
from pbgi.v1 import scene_pb2


def volume_def(prim, matrix, time, xforms, materials, stream):
    """The SceneChunk for a UsdVol.Volume, or None if it has no usable field."""
    path = str(prim.GetPath())
    volume = UsdVol.Volume(prim)
    chunk = scene_pb2.SceneChunk()
    v = chunk.volume
    v.prim_path = path
    v.material_id = materials.for_prim(prim)
    v.local_to_world.extend(matrix_floats(matrix))
    stage = prim.GetStage()
    for name, target in sorted(volume.GetFieldPaths().items()):
        field = stage.GetPrimAtPath(target)
        if not field or not field.IsA(UsdVol.OpenVDBAsset):
            kind = field.GetTypeName() if field else "a missing prim"
            stream.diagnostic(WARNING, path, f"field '{name}' targets {kind} ({target}), not an "
                              "OpenVDBAsset: skipped", kind=f"volume-field:{name}")
            continue
        asset = UsdVol.OpenVDBAsset(field)
        file_path = asset.GetFilePathAttr().Get(time)
        resolved = file_path.resolvedPath if file_path is not None else ""
        if not resolved:
            shown = file_path.path if file_path is not None else ""
            if shown:
                stream.check_file(unresolved_location(asset.GetFilePathAttr(), shown),
                                  f"volume {path}: the OpenVDB file of field '{name}'")
            stream.diagnostic(WARNING, path, f"field '{name}': cannot resolve the file "
                              f"'{shown}' of {target}: skipped", kind=f"volume-file:{name}")
            continue
        f = v.fields.add()
        f.name = str(name)
        f.file = resolved
        f.grid_name = str(asset.GetFieldNameAttr().Get(time) or "")
        index = asset.GetFieldIndexAttr()
        f.field_index = int(index.Get(time)) if index.HasAuthoredValue() else -1
        f.local_to_world.extend(matrix_floats(xforms.GetLocalToWorldTransform(field)))
    if not v.fields:
        stream.diagnostic(WARNING, path, "volume without a readable OpenVDB field: skipped",
                          kind="volume-empty")
        return None
    return chunk
