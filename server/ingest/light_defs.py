"""UsdLux lights -> LightDef.

radiance = color * intensity * 2^exposure (* blackbody colour if enabled),
divided by the light's world-space area when inputs:normalize is true, so
that the power does not change with the light's size. For a DistantLight
the value is the irradiance it delivers (normalize does not apply).
Rect and disk lights emit from their local -Z side only.
"""
import math

import numpy as np
from pxr import Gf, UsdLux

from chunk_stream import WARNING
from pbgi.v1 import scene_pb2

SUPPORTED = {
    "RectLight": scene_pb2.LightDef.RECT,
    "SphereLight": scene_pb2.LightDef.SPHERE,
    "DiskLight": scene_pb2.LightDef.DISK,
    "DistantLight": scene_pb2.LightDef.DISTANT,
}


def is_light(prim):
    return prim.HasAPI(UsdLux.LightAPI)


def matrix_floats(matrix):
    """16 floats, row-major, USD row-vector convention (p' = p * M)."""
    return [float(matrix[i][j]) for i in range(4) for j in range(4)]


def _axis_lengths(matrix):
    return [Gf.Vec3d(*matrix.TransformDir(Gf.Vec3d(*e))).GetLength()
            for e in ((1, 0, 0), (0, 1, 0), (0, 0, 1))]


def _get(attr, time, default):
    value = attr.Get(time) if attr else None
    return default if value is None else value


def light_def(prim, matrix, time, stream):
    """LightDef chunk for a supported light, or None (after reporting why)."""
    path = str(prim.GetPath())
    kind = SUPPORTED.get(prim.GetTypeName())
    if kind is None:
        stream.diagnostic(WARNING, path, f"{prim.GetTypeName() or 'light'} is not supported yet: "
                          "it contributes no light", kind="unsupported-light")
        return None
    api = UsdLux.LightAPI(prim)
    color = np.array(_get(api.GetColorAttr(), time, Gf.Vec3f(1, 1, 1)), dtype=np.float64)
    scale = float(_get(api.GetIntensityAttr(), time, 1.0)) * \
        2.0 ** float(_get(api.GetExposureAttr(), time, 0.0))
    if _get(api.GetEnableColorTemperatureAttr(), time, False):
        kelvin = float(_get(api.GetColorTemperatureAttr(), time, 6500.0))
        color *= np.array(UsdLux.BlackbodyTemperatureAsRgb(kelvin), dtype=np.float64)

    chunk = scene_pb2.SceneChunk()
    light = chunk.light
    light.prim_path = path
    light.kind = kind
    light.local_to_world.extend(matrix_floats(matrix))
    sx, sy, sz = _axis_lengths(matrix)
    area = 0.0
    if kind == scene_pb2.LightDef.RECT:
        light.width = float(_get(prim.GetAttribute("inputs:width"), time, 1.0))
        light.height = float(_get(prim.GetAttribute("inputs:height"), time, 1.0))
        area = light.width * sx * light.height * sy
        if prim.GetAttribute("inputs:texture:file").HasAuthoredValue():
            stream.diagnostic(WARNING, path, "rect light texture is not modelled: uniform color",
                              kind="light-texture")
    elif kind == scene_pb2.LightDef.DISK:
        light.radius = float(_get(prim.GetAttribute("inputs:radius"), time, 0.5))
        area = math.pi * light.radius ** 2 * sx * sy
    elif kind == scene_pb2.LightDef.SPHERE:
        light.radius = float(_get(prim.GetAttribute("inputs:radius"), time, 0.5))
        if _get(prim.GetAttribute("treatAsPoint"), time, False):
            light.radius = 0.0
        mean_scale = (sx * sy * sz) ** (1.0 / 3.0)
        area = 4.0 * math.pi * (light.radius * mean_scale) ** 2
    else:
        light.angle_degrees = float(_get(prim.GetAttribute("inputs:angle"), time, 0.53))

    if kind != scene_pb2.LightDef.DISTANT and _get(api.GetNormalizeAttr(), time, False):
        if area > 0.0:
            scale /= area
        else:
            stream.diagnostic(WARNING, path, "normalize on a light of zero area is ignored",
                              kind="light-normalize")
    if prim.HasAPI(UsdLux.ShapingAPI):
        stream.diagnostic(WARNING, path, "light shaping (cone, IES) is not modelled",
                          kind="light-shaping")
    radiance = color * scale
    light.radiance.x, light.radiance.y, light.radiance.z = (float(c) for c in radiance)
    return chunk
