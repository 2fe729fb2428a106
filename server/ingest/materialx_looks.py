"""MaterialX looks (.mtlx documents referenced from USD) -> MaterialDef.

Assets exported from current DCCs bind Materials that reference a MaterialX
document: `def Material "M" (references = @look.mtlx@</MaterialX/Materials/M>)`.
usd-core has no UsdMtlx file-format plug-in, so USD reports the arc as a
composition error and the Material has no shaders. The reader reads the
document itself with the official MaterialX Python package (`materialx` on
PyPI) and maps the material's surface shader onto the scene's material model
(MaterialTable's Resolved: base colour, metalness, specular roughness and
IOR, emission), with the defaults of the shader's own nodedef from
MaterialX's standard libraries:

  standard_surface   base x base_color, metalness, specular_roughness,
                     specular_IOR, emission x emission_color, opacity (mean)
  open_pbr_surface   base_weight x base_color, base_metalness,
                     specular_roughness, specular_ior,
                     emission_luminance x emission_color, geometry_opacity

An input is a constant, or a graph of `image`/`tiledimage` (file, its colour
space: srgb_texture read as sRGB, lin_rec709 and raw as linear; the
address modes; a `texcoord` of index 0 or none: the mesh's st; tiledimage's
uvtiling as an st transform) under `multiply` and `add` by constants (the
texture's scale and bias) and `dot` pass-throughs; textures drive the base
and emission colours (the model's textured inputs). Whatever else the
material authors -- coat, sheen, transmission, subsurface, a
specular tint, a texture on roughness or opacity, an unsupported node -- is listed in
one WARNING per material (kind "materialx"), never silently dropped. The
arc's composition error itself is then not reported.
"""
import math
import os
import re

try:
    import MaterialX as mx
    _IMPORT_ERROR = None
except ImportError as e:  # reported once per material that needs it
    mx = None
    _IMPORT_ERROR = e

from asset_roots import OutsideRoots
from chunk_stream import WARNING
from pbgi.v1 import scene_pb2
from preview_materials import Resolved, TextureSpec

# shader category -> model input -> (MaterialX input, or None: the model's default)
_INPUTS = {
    "standard_surface": {
        "base": "base", "base_color": "base_color", "roughness": "specular_roughness",
        "metalness": "metalness", "ior": "specular_IOR", "emission": "emission",
        "emission_color": "emission_color", "opacity": "opacity",
    },
    "open_pbr_surface": {
        "base": "base_weight", "base_color": "base_color", "roughness": "specular_roughness",
        "metalness": "base_metalness", "ior": "specular_ior", "emission": "emission_luminance",
        "emission_color": "emission_color", "opacity": "geometry_opacity",
    },
}
_TEXTURED = ("base_color", "emission_color")
_WRAPS = {"clamp": scene_pb2.TextureRef.CLAMP, "periodic": scene_pb2.TextureRef.REPEAT,
          "mirror": scene_pb2.TextureRef.MIRROR, "constant": scene_pb2.TextureRef.BLACK}
_SRGB = ("srgb_texture", "srgb_displayp3")
_LINEAR = ("lin_rec709", "raw", "", "lin_srgb")
_GREY = (0.5, 0.5, 0.5)


def _library():
    """MaterialX's standard libraries (nodedefs with the shaders' defaults), once."""
    if not hasattr(_library, "doc"):
        lib = mx.createDocument()
        mx.loadLibraries(mx.getDefaultDataLibraryFolders(), mx.getDefaultDataSearchPath(), lib)
        _library.doc = lib
    return _library.doc


_MTLX_ASSET = re.compile(r"@([^@]+?\.mtlx)(?::SDF_FORMAT_ARGS[^@]*)?@", re.IGNORECASE)


def mtlx_error_files(error_text):
    """The .mtlx documents a USD composition error is about (an arc usd-core
    cannot compose: no file-format plug-in); MaterialXLooks reads them
    instead, and the stage's content hash covers their bytes."""
    return sorted(set(m.group(1) for m in _MTLX_ASSET.finditer(error_text)))


def _include_reader(roots, files, what):
    """MaterialX's XInclude hook: an included file is resolved as MaterialX
    does (the including document's folder first), confined to the scene
    roots before it is read (OutsideRoots names `what`, never the file),
    recorded in `files`, then read with the same hook (nested includes)."""
    def read(doc, filename, search_path, options):
        path = search_path.find(filename).asString()
        if not os.path.isabs(path):  # found nowhere: where the includer would have it
            folders = [f for f in search_path.asString().split(os.pathsep) if f]
            path = os.path.join(folders[0] if folders else os.getcwd(), path)
        path = os.path.normpath(path)
        if roots is not None:
            roots.check(path, f"a file {what} includes")
        files.append(path)
        mx.readFromXmlFile(doc, path, search_path, options)
    return read


def read_mtlx_document(file, roots, what="a MaterialX document"):
    """(document, [every file read: `file`, then its XIncludes]). Each file
    is checked against `roots` (an AssetRoots or None) before it is read:
    raises OutsideRoots. Raises the MaterialX package's errors for missing
    or malformed documents."""
    if roots is not None:
        roots.check(file, what)
    files = [file]
    options = mx.XmlReadOptions()
    options.readXIncludeFunction = _include_reader(roots, files, f"the MaterialX document '{file}'")
    doc = mx.createDocument()
    mx.readFromXmlFile(doc, file, mx.FileSearchPath(), options)
    return doc, files


def mtlx_document_files(file, roots):
    """The files whose bytes make up a .mtlx look (the document and what it
    XIncludes), for the content hash: editing an included document must
    change it. Confined like the look's own read (raises OutsideRoots);
    a document that cannot be read (or no MaterialX package) is itself
    the only file."""
    if mx is None:
        if roots is not None:
            roots.check(file, "a MaterialX document")
        return [file]
    try:
        return read_mtlx_document(file, roots)[1]
    except Exception as e:
        if isinstance(e, OutsideRoots):
            raise
        return [file]


def mtlx_arcs(prim):
    """[(absolute .mtlx path, material name or "")] of the references and
    payloads authored on `prim` that name a MaterialX document."""
    arcs = []
    for spec in prim.GetPrimStack():
        for op in (spec.referenceList, spec.payloadList):
            for item in list(op.prependedItems) + list(op.appendedItems) + list(op.explicitItems) + \
                    list(op.addedItems):
                path = item.assetPath
                if not path.lower().endswith(".mtlx"):
                    continue
                name = item.primPath.name if not item.primPath.isEmpty else ""
                arcs.append((spec.layer.ComputeAbsolutePath(path), name))
    return arcs


def _value_tuple(value):
    if isinstance(value, (int, float)):
        return (float(value),)
    return tuple(float(x) for x in value)


class _Graph:
    """Evaluates a shader input's upstream graph: a constant tuple, or a
    texture (a dict of TextureSpec fields with scale and bias), or None with
    a problem noted."""

    def __init__(self, document_dir, problems, roots=None):
        self.dir = document_dir
        self.problems = problems
        self.roots = roots  # AssetRoots of the read, or None

    def input(self, inp, what):
        node = inp.getConnectedNode()
        if node is None:
            output = inp.getConnectedOutput()
            node = output.getConnectedNode() if output is not None else None
        if node is None:
            value = inp.getValue()
            return None if value is None else _value_tuple(value)
        return self.node(node, what)

    def node(self, node, what):
        category = node.getCategory()
        if category == "constant":
            return self.input(node.getInput("value"), what) if node.getInput("value") else None
        if category == "dot":
            return self.input(node.getInput("in"), what) if node.getInput("in") else None
        if category in ("image", "tiledimage"):
            return self.image(node, what)
        if category in ("multiply", "add"):
            a = self.input(node.getInput("in1"), what) if node.getInput("in1") else None
            b = self.input(node.getInput("in2"), what) if node.getInput("in2") else None
            if a is None or b is None:
                return None
            if isinstance(a, dict) and isinstance(b, dict):
                self.problems.append(f"{what}: {category} of two textures")
                return None
            texture, constant = (a, b) if isinstance(a, dict) else (b, a)
            if not isinstance(texture, dict):  # two constants
                op = (lambda x, y: x * y) if category == "multiply" else (lambda x, y: x + y)
                return _broadcast(a, b, op)
            c = _rgb(constant)
            if category == "multiply":
                texture["scale"] = tuple(s * k for s, k in zip(texture["scale"], c))
                texture["bias"] = tuple(s * k for s, k in zip(texture["bias"], c))
            else:
                texture["bias"] = tuple(s + k for s, k in zip(texture["bias"], c))
            return texture
        self.problems.append(f"{what}: node {node.getName()} ({category}) is not modelled")
        return None

    def image(self, node, what):
        file_input = node.getInput("file")
        if file_input is None or not file_input.getResolvedValueString():
            self.problems.append(f"{what}: image {node.getName()} has no file")
            return None
        path = file_input.getResolvedValueString()
        if not os.path.isabs(path):
            path = os.path.normpath(os.path.join(self.dir, path))
        if "<UDIM>" in path.upper():
            self.problems.append(f"{what}: UDIM file '{path}' is not supported")
            return None
        if not os.path.isfile(path):
            # Said only of a path inside the scene roots (no existence leak).
            if self.roots is not None:
                self.roots.check(path, f"{what}: the texture file of image {node.getName()}")
            self.problems.append(f"{what}: texture file '{path}' not found")
            return None
        space = file_input.getActiveColorSpace()
        if space in _SRGB:
            color_space = scene_pb2.TextureRef.SRGB
        elif space in _LINEAR:
            color_space = scene_pb2.TextureRef.RAW
        else:
            color_space = scene_pb2.TextureRef.COLOR_SPACE_AUTO
            self.problems.append(f"{what}: colour space '{space}' of '{os.path.basename(path)}' is "
                                 "not modelled: decoded by the file's own metadata")
        st_transform = None
        if node.getCategory() == "tiledimage" and node.getInput("uvtiling"):
            su, sv = _value_tuple(node.getInput("uvtiling").getValue())
            st_transform = (su, 0.0, 0.0, 0.0, sv, 0.0)
        texcoord = node.getInput("texcoord")
        if texcoord is not None:
            source = texcoord.getConnectedNode()
            if source is None or source.getCategory() != "texcoord" or \
                    (source.getInput("index") is not None and source.getInput("index").getValue() != 0):
                self.problems.append(f"{what}: image {node.getName()} texcoord is not UV set 0: "
                                     "read with the mesh's st")

        def wrap(name):
            mode = node.getInput(name)
            return _WRAPS.get(mode.getValueString() if mode is not None else "periodic",
                              scene_pb2.TextureRef.REPEAT)

        return {"file": path, "wrap_s": wrap("uaddressmode"), "wrap_t": wrap("vaddressmode"),
                "scale": (1.0, 1.0, 1.0), "bias": (0.0, 0.0, 0.0), "color_space": color_space,
                "channel": scene_pb2.TextureRef.RGB, "st_transform": st_transform,
                "uv_primvar": "st", "constant_st": (0.0, 0.0)}


def _rgb(value):
    return tuple(value) * 3 if len(value) == 1 else tuple(value[:3])


def _broadcast(a, b, op):
    """op of two constants, a scalar applying to every channel of the other."""
    if len(a) == 1:
        a = a * len(b)
    if len(b) == 1:
        b = b * len(a)
    return tuple(op(x, y) for x, y in zip(a, b))


class MaterialXLooks:
    """Resolves Materials whose look is a referenced .mtlx document."""

    def __init__(self, stream):
        self._stream = stream
        self._documents = {}  # path -> (document or None, error)

    def resolve(self, material_prim):
        """Resolved for a Material that references a .mtlx document, or None
        if it references none."""
        arcs = mtlx_arcs(material_prim)
        if not arcs:
            return None
        path = str(material_prim.GetPath())
        file, name = arcs[0]
        problems = []
        resolved = self._resolve(file, name, problems)
        if problems:
            where = f"{os.path.basename(file)}:{name}" if name else os.path.basename(file)
            self._stream.diagnostic(WARNING, path, f"MaterialX look {where}: not modelled: "
                                    + "; ".join(problems), kind="materialx")
        return resolved

    def _document(self, file):
        if file not in self._documents:
            # The document and its XIncludes are files the scene resolves:
            # confined to the scene roots like its layers (asset_roots.py);
            # raises OutsideRoots, which refuses the whole read.
            roots = getattr(self._stream, "_roots", None)
            try:
                doc, _ = read_mtlx_document(file, roots)
                doc.importLibrary(_library())
                self._documents[file] = (doc, None)
            except OutsideRoots:
                raise
            except Exception as e:  # a missing or malformed document
                self._documents[file] = (None, str(e).strip() or type(e).__name__)
        return self._documents[file]

    def _resolve(self, file, name, problems):
        grey = Resolved(_GREY, (0.0, 0.0, 0.0), 0.5, 0.0, None, None, False)
        if mx is None:
            problems.append(f"the MaterialX package is not installed ({_IMPORT_ERROR}): grey")
            return grey
        doc, error = self._document(file)
        if doc is None:
            problems.append(f"cannot read the document: {error}: grey")
            return grey
        material = doc.getChild(name) if name else (doc.getMaterialNodes() or [None])[0]
        if material is None or material.getCategory() != "surfacematerial":
            problems.append(f"no surfacematerial '{name}' in the document: grey")
            return grey
        shader_input = material.getInput("surfaceshader")
        shader = shader_input.getConnectedNode() if shader_input is not None else None
        category = shader.getCategory() if shader is not None else "nothing"
        if category not in _INPUTS:
            problems.append(f"surface shader is {category}, not standard_surface or "
                            "open_pbr_surface: grey")
            return grey
        return self._map(shader, _INPUTS[category], os.path.dirname(file), problems)

    def _map(self, shader, names, document_dir, problems):
        nodedef = shader.getNodeDef()
        graph = _Graph(document_dir, problems, getattr(self._stream, "_roots", None))
        used = set(names.values())

        def get(key):
            """The input's value (or texture dict for the textured ones), else its default."""
            input_name = names[key]
            default = nodedef.getActiveInput(input_name).getValue() if nodedef else None
            default = _value_tuple(default) if default is not None else (0.0,)
            inp = shader.getInput(input_name)
            if inp is None:
                return default
            got = graph.input(inp, input_name)
            if isinstance(got, dict) and key not in _TEXTURED:
                problems.append(f"{input_name}: textures only drive base and emission colours: "
                                "its default")
                return default
            return default if got is None else got

        base = get("base")[0]
        base_color = get("base_color")
        emission = get("emission")[0]
        emission_color = get("emission_color")
        diffuse, diffuse_texture = _weighted(base_color, base, _GREY)
        emissive, emissive_texture = _weighted(emission_color, emission, (0.0, 0.0, 0.0))
        # Everything else the material authors: listed, not silently lost.
        for inp in shader.getInputs():
            if inp.getName() in used:
                continue
            default = nodedef.getActiveInput(inp.getName()) if nodedef else None
            connected = inp.getConnectedNode() is not None or inp.getConnectedOutput() is not None
            if connected or default is None or inp.getValueString() != default.getValueString():
                problems.append(f"{inp.getName()} = {'(connected)' if connected else inp.getValueString()}")
        # standard_surface's opacity is a colour (its mean: opacity is
        # presence here, server/scene/surface_opacity.h), OpenPBR's a float.
        opacity = get("opacity")
        opacity = sum(opacity) / len(opacity) if opacity else 1.0
        opacity = min(max(float(opacity), 0.0), 1.0) if math.isfinite(opacity) else 1.0
        return Resolved(diffuse, emissive, float(get("roughness")[0]), float(get("metalness")[0]),
                        diffuse_texture, emissive_texture, False, (0.0, 0.0, 0.0), False,
                        float(get("ior")[0]), opacity)


def _weighted(color, weight, stand_in):
    """(constant colour, TextureSpec or None) of weight x colour."""
    if isinstance(color, dict):
        color["scale"] = tuple(weight * s for s in color["scale"])
        color["bias"] = tuple(weight * b for b in color["bias"])
        return tuple(weight * c for c in stand_in), TextureSpec(**color)
    return tuple(weight * c for c in _rgb(color)), None
