"""Bound materials -> MaterialDef.

UsdPreviewSurface: constant diffuseColor, emissiveColor, roughness,
metallic, specularColor, useSpecularWorkflow and ior; diffuseColor and
emissiveColor may also come from a UsdUVTexture (sent as a TextureRef:
resolved file, wrap modes, scale/bias, source colour space, the output
channel, st from a UsdPrimvarReader_float2 -- whose
varname the mesh chunks then carry as uvs -- through an optional
UsdTransform2d; the daemon loads and filters the image) or from the
gprim's displayColor primvar (constant: folded into the material; varying:
sent per vertex with the mesh). Textures on the other inputs are reduced to
their authored value or fallback, with one WARNING. A texture's constant
stand-in (used where the image cannot be read or a mesh has no st) is the
input's own authored value, else the texture's authored fallback, else mid
grey (albedo) or the UsdPreviewSurface default.

Materials that reference a MaterialX document (.mtlx, which usd-core
cannot compose) are read from it by materialx_looks.py. Materials without
a UsdPreviewSurface but with a MaterialX surface authored in USD
(outputs:mtlx:surface: standard_surface, open_pbr_surface, gltf_pbr) are
mapped best-effort to base colour, roughness, metalness and emission from
constant inputs, with one WARNING naming what was approximated.

Materials are de-duplicated by (material path, resolved values): one id per
distinct result.
"""
import collections
import math

import numpy as np
from pxr import UsdGeom, UsdShade

from asset_roots import unresolved_location
from chunk_stream import WARNING
from pbgi.v1 import scene_pb2

# UsdPreviewSurface defaults (spec, version 2.5).
_DEFAULTS = {
    "diffuseColor": (0.18, 0.18, 0.18),
    "emissiveColor": (0.0, 0.0, 0.0),
    "roughness": 0.5,
    "metallic": 0.0,
    "specularColor": (0.0, 0.0, 0.0),
    "useSpecularWorkflow": 0,
    "ior": 1.5,
    "opacity": 1.0,
    "opacityThreshold": 0.0,
}
# Unknown average albedo of a texture: mid grey keeps bounce energy plausible.
_TEXTURE_GREY = (0.5, 0.5, 0.5)
# Albedo of gprims with neither a bound material nor displayColor.
_UNBOUND_GREY = (0.5, 0.5, 0.5)
_CHANNELS = {"r": 0, "g": 1, "b": 2, "a": 3}
_TEXTURED_INPUTS = ("diffuseColor", "emissiveColor", "opacity")

_WRAPS = {"black": scene_pb2.TextureRef.BLACK, "clamp": scene_pb2.TextureRef.CLAMP,
          "repeat": scene_pb2.TextureRef.REPEAT, "mirror": scene_pb2.TextureRef.MIRROR,
          "useMetadata": scene_pb2.TextureRef.USE_METADATA}
_COLOR_SPACES = {"auto": scene_pb2.TextureRef.COLOR_SPACE_AUTO, "sRGB": scene_pb2.TextureRef.SRGB,
                 "raw": scene_pb2.TextureRef.RAW}
_OUTPUT_CHANNELS = {"rgb": scene_pb2.TextureRef.RGB, "r": scene_pb2.TextureRef.R,
                    "g": scene_pb2.TextureRef.G, "b": scene_pb2.TextureRef.B,
                    "a": scene_pb2.TextureRef.A}

# A texture as the material sends it; hashable so that it is part of the
# de-duplication key. st_transform: 6 floats [a b tx; c d ty] or None;
# uv_primvar: the varname st is read from, or None for a constant st.
TextureSpec = collections.namedtuple(
    "TextureSpec", "file wrap_s wrap_t scale bias color_space channel st_transform uv_primvar "
                   "constant_st")

# Resolved material: what MaterialDef carries. The specular and opacity
# inputs default to UsdPreviewSurface's (MaterialX and displayColor
# materials use them).
Resolved = collections.namedtuple(
    "Resolved", "diffuse emissive roughness metallic diffuse_texture emissive_texture vertex_colors "
                "specular use_specular_workflow ior opacity opacity_texture opacity_threshold",
    defaults=(_DEFAULTS["specularColor"], False, _DEFAULTS["ior"], _DEFAULTS["opacity"], None,
              _DEFAULTS["opacityThreshold"]))

# MaterialX surfaces: node id -> (base colour inputs (weight, colour),
# roughness, metalness, emission (weight, colour)) with the defaults of each
# specification (Autodesk Standard Surface 1.0.1, OpenPBR 1.1, glTF 2.0).
_MTLX = {
    "ND_standard_surface_surfaceshader": {
        "base": ("base", 0.8), "base_color": ("base_color", (1.0, 1.0, 1.0)),
        "roughness": ("specular_roughness", 0.2), "metalness": ("metalness", 0.0),
        "emission": ("emission", 0.0), "emission_color": ("emission_color", (1.0, 1.0, 1.0)),
        "opacity": ("opacity", (1.0, 1.0, 1.0)),
    },
    "ND_open_pbr_surface_surfaceshader": {
        "base": ("base_weight", 1.0), "base_color": ("base_color", (0.8, 0.8, 0.8)),
        "roughness": ("specular_roughness", 0.3), "metalness": ("base_metalness", 0.0),
        "emission": ("emission_luminance", 0.0),
        "emission_color": ("emission_color", (1.0, 1.0, 1.0)),
        "opacity": ("geometry_opacity", 1.0),
    },
    "ND_gltf_pbr_surfaceshader": {
        "base": (None, 1.0), "base_color": ("base_color", (1.0, 1.0, 1.0)),
        "roughness": ("roughness", 1.0), "metalness": ("metallic", 1.0),
        "emission": ("emissive_strength", 1.0), "emission_color": ("emissive", (0.0, 0.0, 0.0)),
        "opacity": (None, 1.0),
    },
}


def _as_color(value):
    if value is None:
        return None
    v = [float(x) for x in value]
    if len(v) == 1:
        v *= 3
    return tuple(v[:3])


def _display_color_values(prim, time):
    """(values (N, 3) float64, interpolation) of displayColor, or (None, None)."""
    primvar = UsdGeom.PrimvarsAPI(prim).GetPrimvar("displayColor")
    if not primvar or not primvar.HasValue():
        return None, None
    values = primvar.ComputeFlattened(time)
    if values is None or len(values) == 0:
        return None, None
    return np.asarray(values, dtype=np.float64).reshape(-1, 3), primvar.GetInterpolation()


def display_color(prim, time):
    """Constant displayColor of a gprim (the mean if it varies), or None."""
    values, _ = _display_color_values(prim, time)
    if values is None:
        return None
    return tuple(float(x) for x in values.mean(axis=0))


def display_color_varies(prim, time):
    """True if displayColor differs between the gprim's points/faces/corners."""
    values, interpolation = _display_color_values(prim, time)
    if values is None or interpolation == UsdGeom.Tokens.constant or len(values) < 2:
        return False
    return bool(np.any(values != values[0]))


class MaterialTable:
    """Resolves and de-duplicates materials; writes a MaterialDef the first
    time each distinct material is used (before any mesh refers to it)."""

    def __init__(self, stream, time, looks=None):
        self._stream = stream
        self._time = time
        self._looks = looks  # MaterialXLooks: Materials that reference a .mtlx document
        self._ids = {}
        self._by_id = {}  # material id -> Resolved
        # Resolved values of materials that do not read gprim primvars.
        self._resolved = {}
        self._reads_primvars = False
        self._vertex_colors = False

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
            return self._id((path,) + tuple(values), path, values)
        color = display_color(gprim, self._time)
        # Named after the first gprim whose displayColor it is; the shared
        # grey of unbound, uncoloured gprims has no prim.
        name = str(gprim.GetPath()) if color is not None else ""
        values = Resolved(color or _UNBOUND_GREY, _DEFAULTS["emissiveColor"],
                          _DEFAULTS["roughness"], _DEFAULTS["metallic"], None, None,
                          display_color_varies(gprim, self._time))
        return self._id(("displayColor",) + tuple(values), name, values)

    def uv_primvars(self, material_ids):
        """The st primvars the textures of these materials read, in order of
        first use (a mesh chunk carries one: the first)."""
        names = []
        for material_id in np.unique(np.asarray(material_ids)).tolist():
            r = self._by_id[int(material_id)]
            for t in (r.diffuse_texture, r.emissive_texture, r.opacity_texture):
                if t is not None and t.uv_primvar and t.uv_primvar not in names:
                    names.append(t.uv_primvar)
        return names

    def wants_vertex_colors(self, material_ids):
        return any(self._by_id[int(m)].vertex_colors
                   for m in np.unique(np.asarray(material_ids)).tolist())

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
        self._by_id[material_id] = values
        chunk = scene_pb2.SceneChunk()
        m = chunk.material
        m.id = material_id
        m.prim_path = prim_path
        m.diffuse_color.x, m.diffuse_color.y, m.diffuse_color.z = values.diffuse
        m.emissive_color.x, m.emissive_color.y, m.emissive_color.z = values.emissive
        m.roughness = values.roughness
        m.metallic = values.metallic
        m.specular_color.x, m.specular_color.y, m.specular_color.z = values.specular
        m.use_specular_workflow = bool(values.use_specular_workflow)
        m.ior = values.ior
        if values.diffuse_texture is not None:
            _fill_texture_ref(m.diffuse_texture, values.diffuse_texture)
        if values.emissive_texture is not None:
            _fill_texture_ref(m.emissive_texture, values.emissive_texture)
        m.diffuse_from_vertex_colors = bool(values.vertex_colors)
        m.opacity = min(max(float(values.opacity), 0.0), 1.0)
        if values.opacity_texture is not None:
            _fill_texture_ref(m.opacity_texture, values.opacity_texture)
        m.opacity_threshold = min(max(float(values.opacity_threshold), 0.0), 1.0)
        self._stream.write(chunk)
        return material_id

    def _resolve(self, material, gprim):
        path = str(material.GetPath())
        surface = material.ComputeSurfaceSource()
        shader = surface[0] if surface else None
        if not shader or shader.GetShaderId() != "UsdPreviewSurface":
            from_document = self._looks.resolve(material.GetPrim()) if self._looks else None
            if from_document is not None:
                return from_document
            mtlx = material.ComputeSurfaceSource("mtlx")
            if mtlx and mtlx[0] and mtlx[0].GetShaderId() in _MTLX:
                return self._resolve_materialx(mtlx[0], path)
            found = shader.GetShaderId() if shader else (
                mtlx[0].GetShaderId() if mtlx and mtlx[0] else "nothing")
            self._stream.diagnostic(
                WARNING, path, f"surface is {found}, not UsdPreviewSurface: using grey",
                kind="not-preview-surface")
            return Resolved(_TEXTURE_GREY, _DEFAULTS["emissiveColor"], _DEFAULTS["roughness"],
                            _DEFAULTS["metallic"], None, None, False)
        self._vertex_colors = False
        diffuse, diffuse_texture = self._input(shader, "diffuseColor", gprim, path)
        emissive, emissive_texture = self._input(shader, "emissiveColor", gprim, path)
        roughness, _ = self._input(shader, "roughness", gprim, path)
        metallic, _ = self._input(shader, "metallic", gprim, path)
        specular, _ = self._input(shader, "specularColor", gprim, path)
        workflow, _ = self._input(shader, "useSpecularWorkflow", gprim, path)
        ior, _ = self._input(shader, "ior", gprim, path)
        opacity, opacity_texture = self._input(shader, "opacity", gprim, path)
        threshold, _ = self._input(shader, "opacityThreshold", gprim, path)
        return Resolved(_as_color(diffuse), _as_color(emissive), float(roughness[0]),
                        float(metallic[0]), diffuse_texture, emissive_texture,
                        self._vertex_colors, _as_color(specular), bool(workflow[0]),
                        float(ior[0]), _finite_unit(opacity[0], 1.0), opacity_texture,
                        _finite_unit(threshold[0], 0.0))

    def _input(self, shader, name, gprim, material_path):
        """(constant value, TextureSpec or None) of a UsdPreviewSurface input."""
        default = _DEFAULTS[name]
        grey = _TEXTURE_GREY if name == "diffuseColor" else default
        inp = shader.GetInput(name)
        if not inp:
            return _to_seq(default), None
        attrs = inp.GetValueProducingAttributes()
        if not attrs:
            return _to_seq(default), None
        attr = attrs[0]
        if UsdShade.Input.IsInput(attr):
            value = attr.Get(self._time)
            return _to_seq(default if value is None else value), None
        # Connected to a node's output: primvar readers and textures.
        source = UsdShade.Shader(attr.GetPrim())
        node = source.GetShaderId() or ""
        output = UsdShade.Output(attr).GetBaseName()
        if node.startswith("UsdPrimvarReader"):
            varname = _input_value(source, "varname", self._time)
            varname = str(varname) if varname is not None else ""
            if varname == "displayColor":
                self._reads_primvars = True
                color = display_color(gprim, self._time)
                if color is not None:
                    if name == "diffuseColor" and display_color_varies(gprim, self._time):
                        self._vertex_colors = True
                    return color, None
            fallback = source.GetInput("fallback")
            if fallback and fallback.Get() is not None:
                return _to_seq(fallback.Get()), None
            self._stream.diagnostic(
                WARNING, material_path,
                f"{name} reads primvar '{varname}', which is not modelled: using {_fmt(grey)}",
                kind=f"primvar:{name}")
            return _to_seq(grey), None
        own = inp.GetAttr().Get(self._time)
        if own is not None:
            value, how = own, f"its authored value {_fmt(own)}"
        elif node == "UsdUVTexture" and source.GetInput("fallback") and \
                source.GetInput("fallback").GetAttr().HasAuthoredValue():
            value, how = _pick(source.GetInput("fallback").Get(), output), "the texture's fallback"
        else:
            value, how = grey, _fmt(grey)
        if node == "UsdUVTexture" and name in _TEXTURED_INPUTS:
            spec, problem = self._texture_spec(source, output, material_path)
            if spec is not None:
                return _to_seq(value), spec
            self._stream.diagnostic(WARNING, material_path,
                                    f"{name} texture {source.GetPath()}: {problem}: using {how}",
                                    kind=f"texture:{name}")
            return _to_seq(value), None
        self._stream.diagnostic(
            WARNING, material_path,
            f"{name} is connected to {node or 'a shader'} {source.GetPath()}; only diffuseColor "
            f"emissiveColor and opacity textures are modelled: using {how}", kind=f"texture:{name}")
        return _to_seq(value), None

    def _texture_spec(self, texture, output, material_path):
        """(TextureSpec, None) for a UsdUVTexture, or (None, why not)."""
        if output not in _OUTPUT_CHANNELS:
            return None, f"output '{output}' is not rgb, r, g, b or a"
        asset = _input_value(texture, "file", self._time)
        authored = getattr(asset, "path", "") if asset is not None else ""
        if not authored:
            return None, "no file"
        if "<UDIM>" in authored or "<udim>" in authored.lower():
            return None, f"UDIM file '{authored}' is not supported"
        resolved = getattr(asset, "resolvedPath", "")
        if not resolved:
            self._stream.check_file(unresolved_location(_input_attr(texture, "file"), authored),
                                    f"material {material_path}: a texture file")
            return None, f"file '{authored}' not found"
        channel = _OUTPUT_CHANNELS[output]
        k = _CHANNELS.get(output)
        scale = _input_value(texture, "scale", self._time)
        bias = _input_value(texture, "bias", self._time)
        scale = tuple(float(x) for x in scale) if scale is not None else (1.0, 1.0, 1.0, 1.0)
        bias = tuple(float(x) for x in bias) if bias is not None else (0.0, 0.0, 0.0, 0.0)
        # A single channel is replicated: its own scale and bias on all three.
        scale = (scale[k],) * 3 if k is not None else scale[:3]
        bias = (bias[k],) * 3 if k is not None else bias[:3]
        st_transform, uv_primvar, constant_st, problem = self._st_source(texture)
        if problem:
            self._stream.diagnostic(WARNING, material_path,
                                    f"texture {texture.GetPath()}: {problem}", kind="texture-st")
        return TextureSpec(
            file=resolved,
            wrap_s=_WRAPS.get(str(_input_value(texture, "wrapS", self._time) or "useMetadata"),
                              scene_pb2.TextureRef.USE_METADATA),
            wrap_t=_WRAPS.get(str(_input_value(texture, "wrapT", self._time) or "useMetadata"),
                              scene_pb2.TextureRef.USE_METADATA),
            scale=scale, bias=bias,
            color_space=_COLOR_SPACES.get(
                str(_input_value(texture, "sourceColorSpace", self._time) or "auto"),
                scene_pb2.TextureRef.COLOR_SPACE_AUTO),
            channel=channel, st_transform=st_transform, uv_primvar=uv_primvar,
            constant_st=constant_st), None

    def _st_source(self, texture):
        """(st_transform or None, primvar name or None, constant st, problem)
        of a texture's st input: a UsdPrimvarReader_float2, optionally
        through one UsdTransform2d, or a constant."""
        transform = None
        node, output_attr = _connected(texture.GetInput("st"))
        if node is None:
            st = _input_value(texture, "st", self._time)
            st = tuple(float(x) for x in st) if st is not None else (0.0, 0.0)
            return None, None, st, None
        if (node.GetShaderId() or "") == "UsdTransform2d":
            transform = _transform2d(node, self._time)
            inner, _ = _connected(node.GetInput("in"))
            if inner is None:
                st = _input_value(node, "in", self._time)
                st = tuple(float(x) for x in st) if st is not None else (0.0, 0.0)
                return transform, None, st, None
            node = inner
        node_id = node.GetShaderId() or ""
        if not node_id.startswith("UsdPrimvarReader"):
            return transform, None, (0.0, 0.0), f"st comes from {node_id or 'a shader'}, which " \
                "is not modelled: constant st (0, 0)"
        varname = _input_value(node, "varname", self._time)
        varname = str(varname) if varname is not None else ""
        if not varname:
            return transform, None, (0.0, 0.0), "st primvar reader has no varname: constant st"
        return transform, varname, (0.0, 0.0), None

    def _resolve_materialx(self, shader, path):
        node = shader.GetShaderId()
        table = _MTLX[node]
        approximated = []

        def value(key):
            name, default = table[key]
            if name is None:
                return default
            inp = shader.GetInput(name)
            attrs = inp.GetValueProducingAttributes() if inp else []
            if attrs and not UsdShade.Input.IsInput(attrs[0]):
                approximated.append(f"{name} (connected: its default)")
                return default
            got = attrs[0].Get(self._time) if attrs else None
            return default if got is None else got

        base = float(value("base"))
        base_color = _as_color(value("base_color"))
        emission = float(value("emission"))
        emission_color = _as_color(value("emission_color"))
        roughness = float(value("roughness"))
        metallic = float(value("metalness"))
        opacity = _as_color(value("opacity"))  # standard_surface's is a colour: its mean
        opacity = _finite_unit(sum(opacity) / 3.0, 1.0)
        diffuse = tuple(base * c for c in base_color)
        emissive = tuple(emission * c for c in emission_color)
        note = "; ".join(approximated)
        self._stream.diagnostic(
            WARNING, path,
            f"MaterialX {node} approximated by a base-colour/roughness/metalness surface "
            f"(Lambert + GGX, as UsdPreviewSurface): base colour {_fmt(diffuse)}, "
            f"roughness {roughness:g}, metalness {metallic:g}, emission {_fmt(emissive)}, "
            f"opacity {opacity:g}; "
            f"specular colour and IOR take their defaults; coat, sheen, transmission, "
            f"subsurface and thin-film ignored"
            + (f"; {note}" if note else ""), kind="materialx")
        return Resolved(diffuse, emissive, roughness, metallic, None, None, False,
                        opacity=opacity)


def _finite_unit(value, fallback):
    """value clamped to [0, 1]; `fallback` if it is not a finite number."""
    try:
        v = float(value)
    except (TypeError, ValueError):
        return fallback
    return min(max(v, 0.0), 1.0) if math.isfinite(v) else fallback


def _fill_texture_ref(ref, spec):
    ref.file = spec.file
    ref.wrap_s = spec.wrap_s
    ref.wrap_t = spec.wrap_t
    ref.scale.x, ref.scale.y, ref.scale.z = spec.scale
    ref.bias.x, ref.bias.y, ref.bias.z = spec.bias
    ref.source_color_space = spec.color_space
    ref.channel = spec.channel
    if spec.st_transform is not None:
        ref.st_transform.extend(spec.st_transform)
    ref.uses_uvs = spec.uv_primvar is not None
    ref.constant_s, ref.constant_t = spec.constant_st


def _connected(inp):
    """(source shader, output attribute) an input is connected to (through
    node-graph interfaces), or (None, None)."""
    if not inp:
        return None, None
    attrs = inp.GetValueProducingAttributes()
    if not attrs or UsdShade.Input.IsInput(attrs[0]):
        return None, None
    return UsdShade.Shader(attrs[0].GetPrim()), attrs[0]


def _input_attr(shader, name):
    """The attribute holding an input's value (through interface inputs)."""
    inp = shader.GetInput(name)
    if not inp:
        return None
    attrs = inp.GetValueProducingAttributes()
    return attrs[0] if attrs and UsdShade.Input.IsInput(attrs[0]) else inp.GetAttr()


def _input_value(shader, name, time):
    """Value of an input, following connections to material/node-graph
    interface inputs; None if unauthored and without a fallback."""
    inp = shader.GetInput(name)
    if not inp:
        return None
    attrs = inp.GetValueProducingAttributes()
    if attrs and UsdShade.Input.IsInput(attrs[0]):
        return attrs[0].Get(time)
    return inp.Get(time)


def _transform2d(node, time):
    """UsdTransform2d as [a b tx; c d ty]: st' = R(rotation) (scale * st) + translation."""
    rotation = _input_value(node, "rotation", time)
    scale = _input_value(node, "scale", time)
    translation = _input_value(node, "translation", time)
    angle = math.radians(float(rotation) if rotation is not None else 0.0)
    sx, sy = (float(x) for x in scale) if scale is not None else (1.0, 1.0)
    tx, ty = (float(x) for x in translation) if translation is not None else (0.0, 0.0)
    c, s = math.cos(angle), math.sin(angle)
    return (c * sx, -s * sy, tx, s * sx, c * sy, ty)


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
