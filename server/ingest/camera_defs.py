"""UsdGeom.Camera -> CameraDef (focal length, apertures and their offsets as
authored, mm; clipping range in scene units)."""
from pxr import UsdGeom

from chunk_stream import WARNING
from light_defs import matrix_floats
from pbgi.v1 import scene_pb2


def camera_def(prim, matrix, time, stream):
    camera = UsdGeom.Camera(prim)
    chunk = scene_pb2.SceneChunk()
    c = chunk.camera
    c.prim_path = str(prim.GetPath())
    c.local_to_world.extend(matrix_floats(matrix))
    c.focal_length = float(camera.GetFocalLengthAttr().Get(time))
    c.horizontal_aperture = float(camera.GetHorizontalApertureAttr().Get(time))
    c.vertical_aperture = float(camera.GetVerticalApertureAttr().Get(time))
    near, far = camera.GetClippingRangeAttr().Get(time)
    c.near_clip, c.far_clip = float(near), float(far)
    if camera.GetProjectionAttr().Get(time) != UsdGeom.Tokens.perspective:
        stream.diagnostic(WARNING, c.prim_path, "orthographic camera: read as perspective",
                          kind="camera-projection")
    c.horizontal_aperture_offset = float(camera.GetHorizontalApertureOffsetAttr().Get(time) or 0.0)
    c.vertical_aperture_offset = float(camera.GetVerticalApertureOffsetAttr().Get(time) or 0.0)
    return chunk
