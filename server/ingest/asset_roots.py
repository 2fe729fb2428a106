"""Confinement of every file a scene uses to the daemon's scene roots.

The daemon checks the scene file it is asked to open against its
--scene-root directories; the reader checks everything that file pulls in
(`--scene-root DIR`, repeatable; none = a local read, unconfined):

1. before the stage is composed, the layer graph is walked from the root
   layer: every sublayer, reference and payload asset a layer names
   (variants included) must lie below a root before it is opened, so a
   layer outside is never even read;
2. after composition, every layer the stage uses (what asset-path
   expressions and search paths resolved to) is checked again;
3. every file path a chunk carries to the daemon (textures, dome maps,
   OpenVDB fields) is checked as the chunk is written (ChunkStream), and a
   Draco file before its bytes are read;
4. a texture, dome map or OpenVDB file USD cannot resolve (it does not
   exist) is checked where it would be (`unresolved_location`) before the
   reader says "not found": otherwise the answer would tell whether a file
   outside the roots exists.

Paths are compared after symlinks are resolved (os.path.realpath), so a
symlink inside a root that points outside is outside. A violation raises
OutsideRoots, whose message names what used the file (the layer inside the
roots, the prim) but never the file: its path, or where a symlink points,
would disclose the filesystem outside the roots. The daemon answers
PERMISSION_DENIED (exit code 5).
"""
import os


class OutsideRoots(Exception):
    """A file the scene uses lies outside every scene root."""


def _outer_package_path(path):
    """'/a/b.usdz[c/d.usda]' -> '/a/b.usdz': the file on disk."""
    if path.endswith("]") and "[" in path:
        return path[:path.index("[")]
    return path


class AssetRoots:
    """The scene roots a read is confined to (empty: unconfined)."""

    def __init__(self, roots=()):
        self.roots = [os.path.realpath(r) for r in roots]

    @property
    def confined(self):
        return bool(self.roots)

    def allows(self, path):
        if not self.roots:
            return True
        if not path:
            return False
        real = os.path.realpath(_outer_package_path(path))
        return any(real != root and os.path.commonpath([real, root]) == root for root in self.roots)

    def check(self, path, what):
        """Raises OutsideRoots naming `what` (never `path`) if path is outside."""
        if not self.allows(path):
            raise OutsideRoots(f"{what} is outside the scene roots")

    def check_chunk(self, chunk):
        """Every file path a SceneChunk carries to the daemon."""
        if not self.roots:
            return
        body = chunk.WhichOneof("body")
        if body == "material":
            m = chunk.material
            for name in ("diffuse_texture", "emissive_texture"):
                if m.HasField(name) and getattr(m, name).file:
                    self.check(getattr(m, name).file, f"material {m.prim_path}: the {name.replace('_', ' ')}")
        elif body == "light" and chunk.light.texture_file:
            self.check(chunk.light.texture_file, f"light {chunk.light.prim_path}: the dome texture")
        elif body == "volume":
            for field in chunk.volume.fields:
                self.check(field.file, f"volume {chunk.volume.prim_path}: the OpenVDB file of field "
                           f"'{field.name}'")


def unresolved_location(attr, authored):
    """Where the asset path `authored` of `attr` points though USD found no
    file there: absolute as authored, else anchored to the layer holding
    the attribute's strongest opinion ("" if it has none)."""
    if os.path.isabs(authored):
        return authored
    stack = attr.GetPropertyStack() if attr else []
    return stack[0].layer.ComputeAbsolutePath(authored) if stack else ""


def _layer_name(layer):
    return layer.realPath or layer.identifier


def check_layer_graph(root_path, roots, sdf):
    """Step 1 above: opens the layers below `root_path` one by one, each
    only after its path was found inside the roots. Returns the opened
    layers (hold them: the stage then composes from the same layers
    instead of reading the files again). Raises OutsideRoots naming the
    layer (inside the roots) that names an asset outside them."""
    held, seen, pending = [], set(), [os.path.abspath(root_path)]
    while pending:
        path = pending.pop()
        if path in seen:
            continue
        seen.add(path)
        layer = sdf.Layer.FindOrOpen(path)
        if layer is None:
            continue  # composition reports it
        held.append(layer)
        for asset in layer.GetCompositionAssetDependencies():
            if not asset or "`" in asset:  # expressions: checked after composition
                continue
            absolute = layer.ComputeAbsolutePath(asset)
            # The authored path is not repeated: it may name the outside.
            roots.check(absolute, f"a sublayer, reference or payload of layer '{_layer_name(layer)}'")
            ext = os.path.splitext(_outer_package_path(absolute))[1].lstrip(".")
            if ext and sdf.FileFormat.FindByExtension(ext) is not None:
                pending.append(_outer_package_path(absolute))
    return held


def check_used_layers(stage, roots):
    """Step 2 above: every non-anonymous layer the composed stage uses."""
    for layer in stage.GetUsedLayers():
        if layer.anonymous:
            continue
        roots.check(layer.realPath, "a layer the stage uses (a sublayer, reference or payload)")
