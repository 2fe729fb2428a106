"""Bound materials -> MaterialDef (constant UsdPreviewSurface parameters).

Only constant values are modelled in this slice. An input driven by a
texture falls back to the input's own authored value, else the texture's
authored `inputs:fallback`, else mid grey (albedo) or the UsdPreviewSurface
default, with one WARNING naming the material. A diffuseColor read from the
`displayColor` primvar (a common pattern) uses the gprim's displayColor.
Materials are de-duplicated by (material path, resolved values): one id per
distinct result.
"""
import numpy as np
from pxr import UsdGeom, UsdShade

from chunk_stream import WARNING
from pbgi.v1 import scene_pb2

# UsdPreviewSurface defaults (spec, version 2.5).
_DEFAULTS = {
    "diffuseColor": (0.18, 0.18, 0.18),
    "emissiveColor": (0.0, 0.0, 0.0),
    "roughness": 0.5,
    "metallic": 0.0,
}
# Unknown average albedo of a texture: mid grey keeps bounce energy plausible.
_TEXTURE_GREY = (0.5, 0.5, 0.5)
# Albedo of gprims with neither a bound material nor displayColor.
_UNBOUND_GREY = (0.5, 0.5, 0.5)
_CHANNELS = {"r": 0, "g": 1, "b": 2, "a": 3}


def _as_color(value):
    if value is None:
        return None
    v = [float(x) for x in value]
    if len(v) == 1:
        v *= 3
    return tuple(v[:3])


def display_color(prim, time):
    """Constant displayColor of a gprim (the mean if it varies), or None."""
    primvar = UsdGeom.PrimvarsAPI(prim).GetPrimvar("displayColor")
    if not primvar or not primvar.HasValue():
        return None
    values = primvar.ComputeFlattened(time)
    if values is None or len(values) == 0:
        return None
    return tuple(float(x) for x in np.asarray(values, dtype=np.float64).reshape(-1, 3).mean(axis=0))


class MaterialTable:
    """Resolves and de-duplicates materials; writes a MaterialDef the first
    time each distinct material is used (before any mesh refers to it)."""

    def __init__(self, stream, time):
        self._stream = stream
        self._time = time
        self._ids = {}
        # Resolved values of materials that do not read gprim primvars.
        self._resolved = {}
        self._reads_primvars = False

    def for_prim(self, prim):
        """Material id of a gprim or GeomSubset (binding, else displayColor)."""
        gprim = prim if not prim.IsA(UsdGeom.Subset) else prim.GetParent()
        material, _ = UsdShade.MaterialBindingAPI(prim).ComputeBoundMaterial(
            UsdShade.Tokens.full)
        if material:
            path = str(material.GetPath())
            values = self._resolved.get(path)
            if values is None:
                self._reads_primvars = False
                values = self._resolve(material, gprim)
                if not self._reads_primvars:
                    self._resolved[path] = values
            return self._id((path,) + values, path, values)
        color = display_color(gprim, self._time)
        # Named after the first gprim whose displayColor it is; the shared
        # grey of unbound, uncoloured gprims has no prim.
        name = str(gprim.GetPath()) if color is not None else ""
        values = (color or _UNBOUND_GREY, _DEFAULTS["emissiveColor"], _DEFAULTS["roughness"],
                  _DEFAULTS["metallic"])
        return self._id(("displayColor",) + values, name, values)

    def subset_materials(self, mesh_prim, face_count, default_id):
        """Per-face material ids from GeomSubsets of family materialBind, or
        None if the mesh has none."""
        subsets = UsdShade.MaterialBindingAPI(mesh_prim).GetMaterialBindSubsets()
        if not subsets:
            return None
        faces = np.full(face_count, default_id, dtype=np.int64)
        for subset in subsets:
            indices = np.asarray(subset.GetIndicesAttr().Get(self._time) or [], dtype=np.int64)
            indices = indices[(indices >= 0) & (indices < face_count)]
            faces[indices] = self.for_prim(subset.GetPrim())
        return faces

    def _id(self, key, prim_path, values):
        found = self._ids.get(key)
        if found is not None:
            return found
        material_id = len(self._ids)
        self._ids[key] = material_id
        chunk = scene_pb2.SceneChunk()
        m = chunk.material
        m.id = material_id
        m.prim_path = prim_path
        diffuse, emissive, roughness, metallic = values
        m.diffuse_color.x, m.diffuse_color.y, m.diffuse_color.z = diffuse
        m.emissive_color.x, m.emissive_color.y, m.emissive_color.z = emissive
        m.roughness = roughness
        m.metallic = metallic
        self._stream.write(chunk)
        return material_id

    def _resolve(self, material, gprim):
        path = str(material.GetPath())
        surface = material.ComputeSurfaceSource()
        shader = surface[0] if surface else None
        if not shader or shader.GetShaderId() != "UsdPreviewSurface":
            found = shader.GetShaderId() if shader else "nothing"
            self._stream.diagnostic(
                WARNING, path, f"surface is {found}, not UsdPreviewSurface: using grey",
                kind="not-preview-surface")
            return (_TEXTURE_GREY, _DEFAULTS["emissiveColor"], _DEFAULTS["roughness"],
                    _DEFAULTS["metallic"])
        diffuse = _as_color(self._input(shader, "diffuseColor", gprim, path))
        emissive = _as_color(self._input(shader, "emissiveColor", gprim, path))
        roughness = float(_as_color(self._input(shader, "roughness", gprim, path))[0])
        metallic = float(_as_color(self._input(shader, "metallic", gprim, path))[0])
        return (diffuse, emissive, roughness, metallic)

    def _input(self, shader, name, gprim, material_path):
        default = _DEFAULTS[name]
        grey = _TEXTURE_GREY if name == "diffuseColor" else default
        inp = shader.GetInput(name)
        if not inp:
            return _to_seq(default)
        attrs = inp.GetValueProducingAttributes()
        if not attrs:
            return _to_seq(default)
        attr = attrs[0]
        if UsdShade.Input.IsInput(attr):
            value = attr.Get(self._time)
            return _to_seq(default if value is None else value)
        # Connected to a node's output: only primvar readers and textures
        # are understood, both reduced to constants.
        source = UsdShade.Shader(attr.GetPrim())
        node = source.GetShaderId() or ""
        output = UsdShade.Output(attr).GetBaseName()
        if node.startswith("UsdPrimvarReader"):
            varname = source.GetInput("varname")
            varname = str(varname.Get()) if varname else ""
            if varname == "displayColor":
                self._reads_primvars = True
                color = display_color(gprim, self._time)
                if color is not None:
                    return color
            fallback = source.GetInput("fallback")
            if fallback and fallback.Get() is not None:
                return _to_seq(fallback.Get())
            self._stream.diagnostic(
                WARNING, material_path,
                f"{name} reads primvar '{varname}', which is not modelled: using {_fmt(grey)}",
                kind=f"primvar:{name}")
            return _to_seq(grey)
        own = inp.GetAttr().Get(self._time)
        if own is not None:
            value, how = own, f"its authored value {_fmt(own)}"
        elif node == "UsdUVTexture" and source.GetInput("fallback") and \
                source.GetInput("fallback").GetAttr().HasAuthoredValue():
            value, how = _pick(source.GetInput("fallback").Get(), output), "the texture's fallback"
        else:
            value, how = grey, _fmt(grey)
        self._stream.diagnostic(
            WARNING, material_path,
            f"{name} is connected to {node or 'a shader'} {source.GetPath()}; textures are not "
            f"modelled yet: using {how}", kind=f"texture:{name}")
        return _to_seq(value)


def _to_seq(value):
    try:
        return tuple(float(x) for x in value)
    except TypeError:
        return (float(value),)


def _pick(value, output):
    """Reads an rgb/rgba/r/g/b/a output of a constant."""
    seq = _to_seq(value)
    if output in _CHANNELS and len(seq) > _CHANNELS[output]:
        return (seq[_CHANNELS[output]],)
    return seq[:3]


def _fmt(value):
    seq = _to_seq(value)
    return f"{seq[0]:g}" if len(seq) == 1 else "(" + ", ".join(f"{x:g}" for x in seq) + ")"
