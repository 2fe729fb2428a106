#!/usr/bin/env python3
"""Writes a large USD scene for scale tests of the surfel and tree builds.

A city: a tessellated ground plane and a grid of blocks x blocks buildings
placed by a UsdGeomPointInstancer over three prototypes (a tower with
tessellated faces, a domed hall, a cone "tree"), with per-instance scales
and rotations, a sun (DistantLight), a sky (DomeLight) and a street-level
camera (/World/Camera) for camera-adaptive sampling. Every prototype face
is diffuse (UsdPreviewSurface).

The surfel count is chosen at build time (SurfelOptions::spacing or
target_surfels), not here: the scene's area is printed so that a spacing
can be picked, e.g. spacing = sqrt(area / surfels).

    .venv/bin/python scripts/gen_large_scene.py --blocks 60 --out /tmp/city.usdc
"""
import argparse
import math
import random
import sys

from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux, UsdShade, Vt

CELL = 12.0  # metres between building centres


def material(stage, path, color):
    m = UsdShade.Material.Define(stage, path)
    s = UsdShade.Shader.Define(stage, path + "/PreviewSurface")
    s.CreateIdAttr("UsdPreviewSurface")
    s.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(*color))
    s.CreateInput("roughness", Sdf.ValueTypeNames.Float).Set(1.0)
    m.CreateSurfaceOutput().ConnectToSource(s.ConnectableAPI(), "surface")
    return m


def mesh(stage, path, points, counts, indices, mat):
    m = UsdGeom.Mesh.Define(stage, path)
    m.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.none)
    m.CreateOrientationAttr(UsdGeom.Tokens.rightHanded)
    m.CreatePointsAttr(Vt.Vec3fArray([Gf.Vec3f(*p) for p in points]))
    m.CreateFaceVertexCountsAttr(Vt.IntArray(counts))
    m.CreateFaceVertexIndicesAttr(Vt.IntArray(indices))
    m.CreateExtentAttr(UsdGeom.Mesh.ComputeExtent(m.GetPointsAttr().Get()))
    UsdShade.MaterialBindingAPI.Apply(m.GetPrim()).Bind(mat)
    return m


def grid_quad(o, u, v, n, points, counts, indices):
    """An n x n grid of quads over the parallelogram o + [0,1]u + [0,1]v
    (normal u x v), appended to the arrays."""
    base = len(points)
    for j in range(n + 1):
        for i in range(n + 1):
            points.append(tuple(o[k] + u[k] * i / n + v[k] * j / n for k in range(3)))
    for j in range(n):
        for i in range(n):
            a = base + j * (n + 1) + i
            counts.append(4)
            indices.extend([a, a + 1, a + n + 2, a + n + 1])


def tower(stage, path, mat, n=6):
    """Unit box [-0.5, 0.5] x [0, 1] x [-0.5, 0.5] (y up), faces outward."""
    p, c, i = [], [], []
    grid_quad((-0.5, 1, 0.5), (1, 0, 0), (0, 0, -1), n, p, c, i)    # top +y
    grid_quad((-0.5, 0, 0.5), (1, 0, 0), (0, 1, 0), n, p, c, i)     # front +z
    grid_quad((0.5, 0, -0.5), (-1, 0, 0), (0, 1, 0), n, p, c, i)    # back -z
    grid_quad((0.5, 0, 0.5), (0, 0, -1), (0, 1, 0), n, p, c, i)     # right +x
    grid_quad((-0.5, 0, -0.5), (0, 0, 1), (0, 1, 0), n, p, c, i)    # left -x
    return mesh(stage, path, p, c, i, mat)


def dome(stage, path, mat, rings=12, segments=24):
    """Upper hemisphere of radius 0.5 on a unit-high drum, outward."""
    p, c, i = [], [], []
    for r in range(rings + 1):
        phi = 0.5 * math.pi * r / rings
        for s in range(segments):
            t = 2 * math.pi * s / segments
            p.append((0.5 * math.cos(phi) * math.cos(t), 0.6 + 0.5 * math.sin(phi), 0.5 * math.cos(phi) * math.sin(t)))
    for r in range(rings):
        for s in range(segments):
            a, b = r * segments + s, r * segments + (s + 1) % segments
            c.append(4)
            i.extend([a, a + segments, b + segments, b])
    base = len(p)
    for s in range(segments):  # drum
        t = 2 * math.pi * s / segments
        p.append((0.5 * math.cos(t), 0.0, 0.5 * math.sin(t)))
        p.append((0.5 * math.cos(t), 0.6, 0.5 * math.sin(t)))
    for s in range(segments):
        a, b = base + 2 * s, base + 2 * ((s + 1) % segments)
        c.append(4)
        i.extend([a, a + 1, b + 1, b])
    return mesh(stage, path, p, c, i, mat)


def cone(stage, path, mat, segments=16):
    p = [(0.0, 1.0, 0.0)]
    for s in range(segments):
        t = 2 * math.pi * s / segments
        p.append((0.4 * math.cos(t), 0.0, 0.4 * math.sin(t)))
    c, i = [], []
    for s in range(segments):
        c.append(3)
        i.extend([0, 1 + (s + 1) % segments, 1 + s])
    return mesh(stage, path, p, c, i, mat)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--blocks", type=int, default=40, help="buildings per side (default 40)")
    ap.add_argument("--ground-tiles", type=int, default=64, help="ground quads per side (default 64)")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--out", required=True, help="output .usda/.usdc")
    a = ap.parse_args()
    rng = random.Random(a.seed)

    stage = Usd.Stage.CreateNew(a.out)
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y)
    UsdGeom.SetStageMetersPerUnit(stage, 1.0)
    world = UsdGeom.Xform.Define(stage, "/World")
    stage.SetDefaultPrim(world.GetPrim())

    mats = [material(stage, f"/World/Looks/M{k}", col) for k, col in enumerate(
        [(0.55, 0.52, 0.48), (0.7, 0.35, 0.25), (0.3, 0.45, 0.6), (0.2, 0.5, 0.2), (0.4, 0.4, 0.42)])]

    size = a.blocks * CELL
    p, c, i = [], [], []
    grid_quad((0, 0, size), (size, 0, 0), (0, 0, -size), a.ground_tiles, p, c, i)  # +y
    mesh(stage, "/World/Ground", p, c, i, mats[4])

    inst = UsdGeom.PointInstancer.Define(stage, "/World/City")
    protos = UsdGeom.Scope.Define(stage, "/World/City/Prototypes")
    tower(stage, "/World/City/Prototypes/Tower", mats[0])
    dome(stage, "/World/City/Prototypes/Dome", mats[1])
    cone(stage, "/World/City/Prototypes/Tree", mats[3])
    inst.CreatePrototypesRel().SetTargets([Sdf.Path("/World/City/Prototypes/Tower"),
                                           Sdf.Path("/World/City/Prototypes/Dome"),
                                           Sdf.Path("/World/City/Prototypes/Tree")])

    positions, scales, orients, ids = [], [], [], []
    area = size * size
    for bx in range(a.blocks):
        for bz in range(a.blocks):
            x, z = (bx + 0.5) * CELL, (bz + 0.5) * CELL
            kind = rng.choices([0, 1, 2], weights=[6, 2, 2])[0]
            w, d = rng.uniform(4, 9), rng.uniform(4, 9)
            h = {0: rng.uniform(4, 60), 1: rng.uniform(4, 10), 2: rng.uniform(3, 8)}[kind]
            positions.append(Gf.Vec3f(x, 0, z))
            scales.append(Gf.Vec3f(w, h, d) if kind != 2 else Gf.Vec3f(w * 0.5, h, w * 0.5))
            angle = rng.uniform(0, math.pi / 2)
            orients.append(Gf.Quath(math.cos(angle / 2), 0, math.sin(angle / 2), 0))
            ids.append(kind)
            if kind == 0:
                area += w * d + 2 * h * (w + d)
            elif kind == 1:
                area += 2 * math.pi * (0.5 * w) * (0.5 * d) + math.pi * w * 0.6 * h
            else:
                area += math.pi * 0.2 * w * math.hypot(0.2 * w, h)
    inst.CreatePositionsAttr(Vt.Vec3fArray(positions))
    inst.CreateScalesAttr(Vt.Vec3fArray(scales))
    inst.CreateOrientationsAttr(Vt.QuathArray(orients))
    inst.CreateProtoIndicesAttr(Vt.IntArray(ids))

    sun = UsdLux.DistantLight.Define(stage, "/World/Sun")
    sun.CreateIntensityAttr(3.0)
    sun.CreateAngleAttr(0.53)
    UsdGeom.Xformable(sun).AddRotateXYZOp().Set(Gf.Vec3f(-55, 30, 0))
    sky = UsdLux.DomeLight.Define(stage, "/World/Sky")
    sky.CreateIntensityAttr(0.3)
    sky.CreateColorAttr(Gf.Vec3f(0.6, 0.75, 1.0))

    cam = UsdGeom.Camera.Define(stage, "/World/Camera")
    cam.CreateFocalLengthAttr(24.0)
    cam.CreateHorizontalApertureAttr(36.0)
    cam.CreateVerticalApertureAttr(20.25)
    xf = UsdGeom.Xformable(cam)
    xf.AddTranslateOp().Set(Gf.Vec3d(CELL * 0.5, 1.7, size - CELL * 0.5))
    xf.AddRotateYOp().Set(-30.0)  # looking into the city along -z, a little to +x

    stage.GetRootLayer().Save()
    tris = 2 * a.ground_tiles ** 2
    print(f"{a.out}: {a.blocks}x{a.blocks} buildings over {size:.0f} m, about {area:.4g} m^2 of surface "
          f"(spacing for N surfels: sqrt({area:.4g} / N)); ground {tris} triangles")
    return 0


if __name__ == "__main__":
    sys.exit(main())
