"""UsdLux lights -> LightDef.

radiance = color * intensity * 2^exposure (* blackbody colour if
enableColorTemperature), divided by the light's world-space surface area
when inputs:normalize is true (rect, disk, sphere, cylinder), so that the
power does not change with the light's size. Dome lights ignore normalize
(UsdLux: sizeFactor = 1). For a DistantLight the value is the irradiance
it delivers on a surface facing it, with or without normalize: the reading
renderers give its intensity (50000 by default, "the Sun"), and what the
schema's normalize = true (sizeFactor pi sin^2(angle/2)) yields; with
normalize = false the schema would make it a radiance over the sun's disk,
some 1e-4 times dimmer, which no scene authored for Storm expects.

Colour temperature: UsdLux.BlackbodyTemperatureAsRgb, USD's own blackbody
table (CIE 1931 chromaticities of the Planckian locus from 1000 K to
10000 K, interpolated with a spline, converted to linear Rec.709 and scaled
to unit luminance; temperatures outside the table are clamped to it),
divided by its value at 6500 K, (1.043, 0.984, 1.035): the schema asks
that 6500 K, the D65 white point of the rendering space, be exactly white.
It multiplies `color`, as the schema says.

Shapes: rect and disk emit from their local -Z side only; spheres and
cylinders (around local X, no end caps) emit outward. UsdLuxShapingAPI's
cone angle, softness, focus and focusTint are sent when any of them is
authored (server/scene/light_shaping.h evaluates them); IES profiles are
reported and ignored.

DomeLight / DomeLight_1: a constant colour, or a lat-long map
(inputs:texture:file, OpenEXR's convention with +Y the pole; formats other
than latlong/automatic are read as lat-long with a WARNING). DomeLight_1's
poleAxis ("Z", or "scene" on a Z-up stage) is folded into the matrix as
the rotation taking +Y to +Z (and +Z to -Y), applied to the dome only.
"""
import math

import numpy as np
from pxr import Gf, UsdGeom, UsdLux

from asset_roots import unresolved_location
from chunk_stream import WARNING
from pbgi.v1 import scene_pb2

SUPPORTED = {
    "RectLight": scene_pb2.LightDef.RECT,
    "SphereLight": scene_pb2.LightDef.SPHERE,
    "DiskLight": scene_pb2.LightDef.DISK,
    "DistantLight": scene_pb2.LightDef.DISTANT,
    "CylinderLight": scene_pb2.LightDef.CYLINDER,
    "DomeLight": scene_pb2.LightDef.DOME,
    "DomeLight_1": scene_pb2.LightDef.DOME,
}
_SHAPED = (scene_pb2.LightDef.RECT, scene_pb2.LightDef.DISK, scene_pb2.LightDef.SPHERE,
           scene_pb2.LightDef.CYLINDER)
_SHAPING_INPUTS = ("inputs:shaping:cone:angle", "inputs:shaping:cone:softness",
                   "inputs:shaping:focus", "inputs:shaping:focusTint")
# Row-vector rotation about +X by +90 degrees: +Y -> +Z, +Z -> -Y.
_Y_POLE_TO_Z = Gf.Matrix4d(1, 0, 0, 0,
                           0, 0, 1, 0,
                           0, -1, 0, 0,
                           0, 0, 0, 1)


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


def light_color(api, time):
    """color * (blackbody rgb if enableColorTemperature), linear Rec.709."""
    color = np.array(_get(api.GetColorAttr(), time, Gf.Vec3f(1, 1, 1)), dtype=np.float64)
    if _get(api.GetEnableColorTemperatureAttr(), time, False):
        kelvin = float(_get(api.GetColorTemperatureAttr(), time, 6500.0))
        color *= blackbody_rgb(kelvin)
    return color


def blackbody_rgb(kelvin):
    """Linear Rec.709 colour of a blackbody, 6500 K = (1, 1, 1)."""
    white = np.array(UsdLux.BlackbodyTemperatureAsRgb(6500.0), dtype=np.float64)
    return np.array(UsdLux.BlackbodyTemperatureAsRgb(kelvin), dtype=np.float64) / white


def _dome(prim, light, matrix, time, stream, path):
    if prim.GetTypeName() == "DomeLight_1":
        pole = str(_get(prim.GetAttribute("poleAxis"), time, "scene"))
        if pole == "scene":
            pole = str(UsdGeom.GetStageUpAxis(prim.GetStage()))
        if pole == "Z":
            matrix = _Y_POLE_TO_Z * matrix
    del light.local_to_world[:]
    light.local_to_world.extend(matrix_floats(matrix))
    asset = _get(prim.GetAttribute("inputs:texture:file"), time, None)
    authored = getattr(asset, "path", "") if asset is not None else ""
    if not authored:
        return
    resolved = getattr(asset, "resolvedPath", "")
    if not resolved:
        stream.check_file(unresolved_location(prim.GetAttribute("inputs:texture:file"), authored),
                          f"light {path}: the dome texture")
        stream.diagnostic(WARNING, path, f"dome texture '{authored}' not found: a constant dome "
                          "of the light's color", kind="dome-texture")
        return
    fmt = str(_get(prim.GetAttribute("inputs:texture:format"), time, "automatic"))
    if fmt not in ("automatic", "latlong"):
        stream.diagnostic(WARNING, path, f"dome texture format '{fmt}' is not supported: read as "
                          "latlong", kind="dome-format")
    light.texture_file = resolved
    if prim.GetRelationship("portals") and prim.GetRelationship("portals").GetTargets():
        stream.diagnostic(WARNING, path, "dome portals are ignored (the whole dome is sampled)",
                          kind="dome-portals")


def _shaping(prim, light, time, stream, path):
    if not prim.HasAPI(UsdLux.ShapingAPI):
        return
    shaping = UsdLux.ShapingAPI(prim)
    if _get(shaping.GetShapingIesFileAttr(), time, None):
        stream.diagnostic(WARNING, path, "IES profiles are not modelled: ignored",
                          kind="light-ies")
    if not any(prim.GetAttribute(name).HasAuthoredValue() for name in _SHAPING_INPUTS):
        return
    if light.kind not in _SHAPED:
        stream.diagnostic(WARNING, path, "light shaping applies to rect, disk, sphere and "
                          "cylinder lights only: ignored", kind="light-shaping")
        return
    s = light.shaping
    s.cone_angle_degrees = float(_get(shaping.GetShapingConeAngleAttr(), time, 90.0))
    s.cone_softness = float(_get(shaping.GetShapingConeSoftnessAttr(), time, 0.0))
    s.focus = float(_get(shaping.GetShapingFocusAttr(), time, 0.0))
    tint = _get(shaping.GetShapingFocusTintAttr(), time, Gf.Vec3f(0, 0, 0))
    s.focus_tint.x, s.focus_tint.y, s.focus_tint.z = (float(c) for c in tint)


def light_def(prim, matrix, time, stream):
    """LightDef chunk for a supported light, or None (after reporting why)."""
    path = str(prim.GetPath())
    kind = SUPPORTED.get(prim.GetTypeName())
    if kind is None:
        stream.diagnostic(WARNING, path, f"{prim.GetTypeName() or 'light'} is not supported yet: "
                          "it contributes no light", kind="unsupported-light")
        return None
    api = UsdLux.LightAPI(prim)
    color = light_color(api, time)
    scale = float(_get(api.GetIntensityAttr(), time, 1.0)) * \
        2.0 ** float(_get(api.GetExposureAttr(), time, 0.0))

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
    elif kind == scene_pb2.LightDef.CYLINDER:
        light.radius = float(_get(prim.GetAttribute("inputs:radius"), time, 0.5))
        light.length = float(_get(prim.GetAttribute("inputs:length"), time, 1.0))
        if _get(prim.GetAttribute("treatAsLine"), time, False):
            stream.diagnostic(WARNING, path, "treatAsLine is a hint: the cylinder keeps its "
                              "radius", kind="light-line")
        # The same area the daemon samples (server/scene/light_sampling.cpp).
        area = 2.0 * math.pi * light.radius * 0.5 * (sy + sz) * light.length * sx
    elif kind == scene_pb2.LightDef.DOME:
        _dome(prim, light, matrix, time, stream, path)
    else:
        light.angle_degrees = float(_get(prim.GetAttribute("inputs:angle"), time, 0.53))

    if kind not in (scene_pb2.LightDef.DISTANT, scene_pb2.LightDef.DOME) and \
            _get(api.GetNormalizeAttr(), time, False):
        if area > 0.0:
            scale /= area
        else:
            stream.diagnostic(WARNING, path, "normalize on a light of zero area is ignored",
                              kind="light-normalize")
    _shaping(prim, light, time, stream, path)
    radiance = color * scale
    light.radiance.x, light.radiance.y, light.radiance.z = (float(c) for c in radiance)
    return chunk
