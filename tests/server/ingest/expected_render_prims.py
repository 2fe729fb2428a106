#!/usr/bin/env python3
"""What USD composition says a renderer must see in a stage (test oracle).

    expected_render_prims.py SCENE

Prints one line per render prim: every active, visible gprim (through
instance proxies, outside PointInstancer prototypes) whose computed purpose
is default or render, with its world-space bounds from UsdGeom.BBoxCache:

    <type>\t<prim path>\t<min x> <min y> <min z> <max x> <max y> <max z>

The time code is the reader's (usd_reader.py): the stage's startTimeCode
if authored, else 0. Exit code 2 if the stage cannot be opened.
"""
import sys

from pxr import Usd, UsdGeom


def main(path):
    try:
        stage = Usd.Stage.Open(path, Usd.Stage.LoadAll)
    except Exception as e:  # Tf.ErrorException
        print(f"cannot open {path}: {e}", file=sys.stderr)
        return 2
    if stage is None:
        return 2
    time = Usd.TimeCode(stage.GetStartTimeCode() if stage.HasAuthoredTimeCodeRange() else 0.0)
    cache = UsdGeom.BBoxCache(time, [UsdGeom.Tokens.default_, UsdGeom.Tokens.render],
                              useExtentsHint=False)
    prims = iter(Usd.PrimRange(stage.GetPseudoRoot(),
                               Usd.TraverseInstanceProxies(Usd.PrimDefaultPredicate)))
    for prim in prims:
        if prim.IsA(UsdGeom.PointInstancer):
            prims.PruneChildren()  # prototypes are not render prims themselves
            continue
        if not prim.IsA(UsdGeom.Gprim):
            continue
        imageable = UsdGeom.Imageable(prim)
        if imageable.ComputeVisibility(time) == UsdGeom.Tokens.invisible:
            continue
        if imageable.ComputePurpose() not in (UsdGeom.Tokens.default_, UsdGeom.Tokens.render):
            continue
        box = cache.ComputeWorldBound(prim).ComputeAlignedRange()
        if box.IsEmpty():
            continue
        lo, hi = box.GetMin(), box.GetMax()
        print(f"{prim.GetTypeName()}\t{prim.GetPath()}\t{lo[0]!r} {lo[1]!r} {lo[2]!r} "
              f"{hi[0]!r} {hi[1]!r} {hi[2]!r}")
    return 0


if __name__ == "__main__":
    if len(sys.argv) != 2:
        print(__doc__, file=sys.stderr)
        sys.exit(2)
    sys.exit(main(sys.argv[1]))
