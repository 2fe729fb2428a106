"""UsdGeomPointInstancer -> prototypes sent once + one transform per instance.

Each instance places one prototype (a target of `prototypes`, chosen by
`protoIndices`) with the transform UsdGeomPointInstancer computes from
positions, orientations, scales (velocities and accelerations applied at
the frame's time) and the prototype root's own xform; invisibleIds and
inactiveIds remove instances. Every Mesh and implicit gprim below the
prototype root is read as the regular traversal would read it (materials,
subsets, normals, subdivision cages), in the prototype root's space:

    gprim -> prototype root (ComputeRelativeTransform)      [prototype geometry]
          -> instance (ComputeInstanceTransformsAtTime)
          -> world (the instancer's local-to-world)         [InstanceBatch]

The geometry goes out once per prototype (prototypes.py); the daemon keeps
one copy and one BVH per prototype. With --flatten-instances every instance
is expanded into world-space triangles instead (all instances of one
prototype gprim then share its prim path), until MAX_INSTANCED_TRIANGLES
triangles, beyond which the rest are dropped with a WARNING.
Nested PointInstancers and lights inside prototypes are skipped with a
WARNING.
"""
import numpy as np
from pxr import UsdGeom

from chunk_stream import WARNING
from prototypes import prototype_gprims, relative_transform

# Flattening budget per PointInstancer (--flatten-instances only).
MAX_INSTANCED_TRIANGLES = 20_000_000


def _instances(prim, time, stream):
    """(prototype targets, protoIndices, transforms, visible mask) or None."""
    path = str(prim.GetPath())
    instancer = UsdGeom.PointInstancer(prim)
    prototypes = instancer.GetPrototypesRel().GetTargets()
    indices = instancer.GetProtoIndicesAttr().Get(time)
    if not prototypes or indices is None or len(indices) == 0:
        return None
    indices = np.asarray(indices, dtype=np.int64)
    transforms = instancer.ComputeInstanceTransformsAtTime(
        time, time, UsdGeom.PointInstancer.IncludeProtoXform, UsdGeom.PointInstancer.IgnoreMask)
    if transforms is None or len(transforms) != len(indices):
        stream.diagnostic(WARNING, path, "instance transforms cannot be computed (positions, "
                          "orientations or scales do not match protoIndices): skipped",
                          kind="instancer-xforms")
        return None
    mask = instancer.ComputeMaskAtTime(time)
    visible = np.ones(len(indices), dtype=bool) if not mask else np.asarray(mask, dtype=bool)
    return prototypes, indices, transforms, visible


def _bad_index(path, p, count, stream):
    stream.diagnostic(WARNING, path, f"protoIndices holds {p} but there are {count} prototypes: "
                      "those instances are skipped", kind="proto-index")


def read_point_instancer(prim, matrix, time, xforms, materials, emitter, stream, table=None):
    """Sends the instancer's prototypes to `table` (a PrototypeTable) and
    places every visible instance; without a table, flattens. Returns the
    number of triangles written now (flattened) or 0."""
    found = _instances(prim, time, stream)
    if found is None:
        return 0
    targets, indices, transforms, visible = found
    path = str(prim.GetPath())
    stage = prim.GetStage()
    roots = []
    for target in targets:
        root = stage.GetPrimAtPath(target)
        if not root:
            stream.diagnostic(WARNING, path, f"prototype {target} does not exist",
                              kind=f"prototype:{target}")
        roots.append(root if root else None)

    if table is not None:
        ids = [table.define(("instancer", path, k), str(root.GetPath()), root, warn_others=True)[0]
               if root is not None else 0 for k, root in enumerate(roots)]
        for i in np.flatnonzero(visible).tolist():
            p = int(indices[i])
            if p < 0 or p >= len(ids):
                _bad_index(path, p, len(ids), stream)
                continue
            table.place(ids[p], transforms[i] * matrix)
        return 0

    gprims = []  # per prototype: [(gprim, reader, transform to the prototype root)]
    for root in roots:
        entries = []
        if root is not None:
            for gprim, reader in prototype_gprims(root, time, stream, warn_others=True)[0]:
                entries.append((gprim, reader, relative_transform(xforms, gprim, root)))
        gprims.append(entries)
    total = 0
    for i in np.flatnonzero(visible).tolist():
        p = int(indices[i])
        if p < 0 or p >= len(gprims):
            _bad_index(path, p, len(gprims), stream)
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
