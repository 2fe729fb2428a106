"""UsdGeomPointInstancer -> the triangles of every instance, flattened.

Each instance places one prototype (a target of `prototypes`, chosen by
`protoIndices`) with the transform UsdGeomPointInstancer computes from
positions, orientations, scales (velocities and accelerations applied at
the frame's time) and the prototype root's own xform; invisibleIds and
inactiveIds remove instances. Every Mesh and implicit gprim below the
prototype root is read as the regular traversal would read it (materials,
subsets, normals, subdivision cages), with the transform

    gprim -> prototype root (ComputeRelativeTransform)
          -> instance (ComputeInstanceTransformsAtTime)
          -> world (the instancer's local-to-world).

All instances of one prototype gprim share its prim path, so the daemon
sees one mesh per prototype gprim. Instances are emitted until
MAX_INSTANCED_TRIANGLES triangles, then the rest are dropped with a
WARNING (the pipeline flattens instances: no instanced BVH yet).
Nested PointInstancers and lights inside prototypes are skipped with a
WARNING.
"""
import numpy as np
from pxr import Gf, Usd, UsdGeom

from chunk_stream import WARNING
from gprim_triangles import read_implicit, read_mesh
from implicit_shapes import is_implicit
from light_defs import is_light

# Flattening budget per PointInstancer.
MAX_INSTANCED_TRIANGLES = 20_000_000


def _prototype_gprims(root, time, stream):
    """(prim, reader) of the readable gprims below a prototype root,
    honouring visibility and purpose as the main traversal does."""
    out = []
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
            stream.diagnostic(WARNING, path, "nested PointInstancer is not supported: skipped",
                              kind="nested-instancer")
            prims.PruneChildren()
        elif is_light(prim) and not prim.IsA(UsdGeom.Gprim):
            stream.diagnostic(WARNING, path, "lights inside PointInstancer prototypes are not "
                              "instanced: skipped", kind="instanced-light")
        elif prim.IsA(UsdGeom.Mesh):
            out.append((prim, read_mesh))
        elif is_implicit(prim):
            out.append((prim, read_implicit))
        elif prim.IsA(UsdGeom.Gprim):
            stream.diagnostic(WARNING, path, f"{prim.GetTypeName()} is not supported yet: skipped",
                              kind=prim.GetTypeName())
    return out


def read_point_instancer(prim, matrix, time, xforms, materials, emitter, stream):
    """Emits every visible instance; returns the number of triangles."""
    path = str(prim.GetPath())
    instancer = UsdGeom.PointInstancer(prim)
    prototypes = instancer.GetPrototypesRel().GetTargets()
    indices = instancer.GetProtoIndicesAttr().Get(time)
    if not prototypes or indices is None or len(indices) == 0:
        return 0
    indices = np.asarray(indices, dtype=np.int64)
    transforms = instancer.ComputeInstanceTransformsAtTime(
        time, time, UsdGeom.PointInstancer.IncludeProtoXform, UsdGeom.PointInstancer.IgnoreMask)
    if transforms is None or len(transforms) != len(indices):
        stream.diagnostic(WARNING, path, "instance transforms cannot be computed (positions, "
                          "orientations or scales do not match protoIndices): skipped",
                          kind="instancer-xforms")
        return 0
    mask = instancer.ComputeMaskAtTime(time)
    visible = np.ones(len(indices), dtype=bool) if not mask else np.asarray(mask, dtype=bool)

    stage = prim.GetStage()
    gprims = []  # per prototype: [(gprim, reader, transform to the prototype root)]
    for target in prototypes:
        root = stage.GetPrimAtPath(target)
        if not root:
            stream.diagnostic(WARNING, path, f"prototype {target} does not exist",
                              kind=f"prototype:{target}")
            gprims.append([])
            continue
        entries = []
        for gprim, reader in _prototype_gprims(root, time, stream):
            if gprim == root:
                # The root's own xform is in the instance transform already.
                relative = Gf.Matrix4d(1.0)
            else:
                relative, _ = xforms.ComputeRelativeTransform(gprim, root)
            entries.append((gprim, reader, relative))
        gprims.append(entries)

    total = 0
    for i in np.flatnonzero(visible).tolist():
        p = int(indices[i])
        if p < 0 or p >= len(gprims):
            stream.diagnostic(WARNING, path, f"protoIndices holds {p} but there are "
                              f"{len(gprims)} prototypes: those instances are skipped",
                              kind="proto-index")
            continue
        instance = transforms[i] * matrix
        for gprim, reader, relative in gprims[p]:
            total += reader(gprim, relative * instance, time, materials, emitter, stream) or 0
        if total > MAX_INSTANCED_TRIANGLES:
            stream.diagnostic(WARNING, path, f"instances beyond {MAX_INSTANCED_TRIANGLES} "
                              f"triangles are dropped (instance {i + 1} of {len(indices)})",
                              kind="instance-budget")
            break
    return total
