"""Instanced geometry: each prototype's gprims sent once, plus transforms.

Native USD instances (instanceable prims) and UsdGeom.PointInstancer
prototypes are both written as (proto/pbgi/v1/scene.proto):

    PrototypeDef {id, prim_path}
    MeshChunk / SubdivCage ... with prototype_id = id, in prototype space
    ...
    InstanceBatch {prototype_id, transforms: 16 float32 per instance}

so the daemon keeps one copy of the geometry and one BVH per prototype.
Batches are buffered and written at the end of the traversal (64 bytes per
instance), so a prototype's geometry always precedes its placements.

A prototype is keyed by what makes its triangles differ:
- native: (USD prototype, the instance prim's bound material). Gprims
  inside a prototype without their own binding inherit the instance's, so
  instances with different bindings get different prototypes; the gprims
  are read through the first instance's instance proxies so that this
  inheritance resolves as the flattened traversal would.
- PointInstancer: (instancer, prototype index).

With flatten=True (the reader's --flatten-instances) nothing is instanced:
callers expand instances into world-space triangles as before.
"""
import numpy as np
from pxr import Gf, Usd, UsdGeom, UsdShade

from asset_roots import OutsideRoots
from chunk_stream import ERROR, WARNING
from gprim_triangles import read_implicit, read_mesh
from implicit_shapes import is_implicit
from light_defs import is_light
from pbgi.v1 import scene_pb2

# Instances per InstanceBatch frame (64 bytes each: 4 MiB frames).
INSTANCES_PER_BATCH = 65536


def prototype_gprims(root, time, stream, warn_others):
    """([(prim, reader)], has_others) for the readable gprims below `root`,
    honouring visibility and purpose as the main traversal does.
    has_others: lights, cameras, volumes or nested instancers below, which
    are not geometry of the prototype (warned about if warn_others)."""
    out = []
    others = False
    prims = iter(Usd.PrimRange(root, Usd.TraverseInstanceProxies(Usd.PrimDefaultPredicate)))
    for prim in prims:
        if not prim.IsA(UsdGeom.Imageable):
            continue
        imageable = UsdGeom.Imageable(prim)
        if imageable.GetVisibilityAttr().Get(time) == UsdGeom.Tokens.invisible or \
                imageable.GetPurposeAttr().Get() not in ("default", "render"):
            prims.PruneChildren()
            continue
        path = str(prim.GetPath())
        if prim.IsA(UsdGeom.PointInstancer):
            others = True
            if warn_others:
                stream.diagnostic(WARNING, path, "nested PointInstancer is not supported: skipped",
                                  kind="nested-instancer")
            prims.PruneChildren()
        elif is_light(prim) and not prim.IsA(UsdGeom.Gprim):
            others = True
            if warn_others:
                stream.diagnostic(WARNING, path, "lights inside PointInstancer prototypes are not "
                                  "instanced: skipped", kind="instanced-light")
        elif prim.IsA(UsdGeom.Mesh):
            out.append((prim, read_mesh))
        elif is_implicit(prim):
            out.append((prim, read_implicit))
        elif prim.IsA(UsdGeom.Gprim):
            stream.diagnostic(WARNING, path, f"{prim.GetTypeName()} is not supported yet: skipped",
                              kind=prim.GetTypeName())
        elif prim.IsA(UsdGeom.Camera) or prim.GetTypeName() == "Volume":
            others = True
    return out, others


def relative_transform(xforms, gprim, root):
    """gprim -> root's space (the root's own xform belongs to the instance)."""
    if gprim == root:
        return Gf.Matrix4d(1.0)
    relative, _ = xforms.ComputeRelativeTransform(gprim, root)
    return relative


class PrototypeTable:
    """Prototypes sent so far and the instance transforms waiting to go out."""

    def __init__(self, stream, time, xforms, materials, emitter):
        self.stream = stream
        self.time = time
        self.xforms = xforms
        self.materials = materials
        self.emitter = emitter
        self._ids = {}        # key -> (prototype id or 0 if it has no triangles, has_others)
        self._pending = {}    # prototype id -> [16-float row-major matrices]
        self._paths = {}      # prototype id -> prim path for batches

    def define(self, key, prim_path, root, warn_others):
        """Sends the prototype below `root` once; returns (id, has_others),
        id 0 when it holds no triangles (its instances are then dropped)."""
        found = self._ids.get(key)
        if found is not None:
            return found
        gprims, others = prototype_gprims(root, self.time, self.stream, warn_others)
        proto_id = len(self._ids) + 1
        chunk = scene_pb2.SceneChunk()
        chunk.prototype.id = proto_id
        chunk.prototype.prim_path = prim_path
        self.stream.write(chunk)
        # Every MeshChunk/SubdivCage written meanwhile belongs to the prototype.
        self.stream.prototype_id = proto_id
        triangles = 0  # in packed arrays; subdivision cages are refined by the daemon
        try:
            for gprim, reader in gprims:
                try:
                    relative = relative_transform(self.xforms, gprim, root)
                    triangles += reader(gprim, relative, self.time, self.materials, self.emitter,
                                        self.stream) or 0
                except OutsideRoots:  # the whole read is refused
                    raise
                except Exception as e:  # one bad gprim must not lose the prototype
                    self.stream.diagnostic(ERROR, str(gprim.GetPath()),
                                           f"skipped: {type(e).__name__}: {e}", kind="prim-failed")
        finally:
            self.stream.prototype_id = 0
        result = (proto_id if gprims else 0, others)
        self._ids[key] = result
        self._paths[proto_id] = prim_path
        return result

    def place(self, proto_id, matrix):
        """One instance of proto_id with prototype -> world `matrix`."""
        if proto_id:
            self._pending.setdefault(proto_id, []).append(np.asarray(matrix, dtype=np.float64).reshape(16))

    def flush(self):
        """Writes every buffered placement as InstanceBatch frames."""
        for proto_id, matrices in sorted(self._pending.items()):
            packed = np.asarray(matrices, dtype="<f4")
            for begin in range(0, len(packed), INSTANCES_PER_BATCH):
                chunk = scene_pb2.SceneChunk()
                chunk.instances.prototype_id = proto_id
                chunk.instances.prim_path = self._paths[proto_id]
                chunk.instances.transforms = packed[begin:begin + INSTANCES_PER_BATCH].tobytes()
                self.stream.write(chunk)
        self._pending.clear()

    def place_native(self, prim, matrix):
        """An instanceable prim: its prototype once, this placement.
        Returns has_others (lights etc. inside, to be read per instance)."""
        prototype = prim.GetPrototype()
        bound, _ = UsdShade.MaterialBindingAPI(prim).ComputeBoundMaterial()
        key = ("native", str(prototype.GetPath()), str(bound.GetPath()) if bound else "")
        proto_id, others = self.define(key, str(prototype.GetPath()), prim, warn_others=False)
        self.place(proto_id, matrix if matrix is not None else Gf.Matrix4d(1.0))
        return others
