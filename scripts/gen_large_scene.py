#!/usr/bin/env python3
"""Writes a large USD scene for scale tests of the surfel and tree builds.

Two kinds, both made of districts of DISTRICT x DISTRICT cells, each district
a separate layer brought in as a *payload* (so USD loads them lazily and the
reader streams them one by one), each holding a UsdGeomPointInstancer:

  city    a grid of buildings over three prototypes (a tower with tessellated
          faces, a domed hall, a cone "tree"), per-instance scales/rotations;
  forest  trees (a trunk and a two-cone crown) and rocks, scattered densely.

Plus a tessellated ground, a sun (DistantLight), a sky (DomeLight) and a
street-level camera (/World/Camera). Every face is diffuse (UsdPreviewSurface).

A third kind, for ingest-memory tests (issue 3: "200 payload-loaded assets
totalling 20M triangles"), has no instancing at all:

  assets  --assets N distinct asset layers (.usdc, next to --out), each one
          non-instanced triangle mesh (a torus displaced along its normal by
          a seeded sum of waves, so no two assets are equal) of about
          --triangles / N triangles, each payloaded on its own prim
          /World/Assets/A<i> on a grid, plus the ground, lights and camera.

    .venv/bin/python scripts/gen_large_scene.py --kind assets --assets 200 \
        --triangles 20e6 --out /work/tmp/assets200/assets.usda

With --subdivision each asset is a dense Catmull-Clark cage (the same grid
as quads) instead: issue 21's "21 subdivision meshes with 400,798 cage
faces" is --assets 21 --triangles 801596 --subdivision.

A fourth kind, for instancing memory (issue 3: "memory reflects the number
of prototypes, not instances"):

  instances  --instances N references to ONE asset layer (the displaced
             torus of --kind assets, --proto-triangles triangles), each an
             `instanceable` Xform /World/Instances/I<i> on a grid with a
             seeded rotation and scale: native USD instances of one
             prototype. --flatten writes the same prims without
             `instanceable` (the flattened equivalent: the reader then
             expands every copy into world-space triangles).

    .venv/bin/python scripts/gen_large_scene.py --kind instances --instances 10000 \
        --proto-triangles 20000 --out /work/tmp/inst10k/instances.usda

Size: --surfels N picks the number of cells so that the scene's surface area
holds N surfels at --spacing metres (area / spacing^2 >= N); --blocks sets it
directly. The defaults reach 100M surfels at the default spacing (5 cm):

    .venv/bin/python scripts/gen_large_scene.py --out /tmp/city/city.usda
    .venv/bin/python scripts/gen_large_scene.py --kind forest --surfels 2e8 --out /tmp/forest/forest.usda
    pbgi render /tmp/city/city.usda --camera /World/Camera --surfel-spacing 0.05 ...

(the district layers are written next to --out). The printed line gives the
area, the cells and the expected surfel count at the spacing.
"""
import argparse
import math
import os
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


def pine(stage, path, mat, segments=12):
    """A trunk (open cylinder r 0.08, 0..0.3) under two stacked cones, unit high."""
    p, c, i = [], [], []
    for s in range(segments):  # trunk
        t = 2 * math.pi * s / segments
        p.append((0.08 * math.cos(t), 0.0, 0.08 * math.sin(t)))
        p.append((0.08 * math.cos(t), 0.3, 0.08 * math.sin(t)))
    for s in range(segments):
        a, b = 2 * s, 2 * ((s + 1) % segments)
        c.append(4)
        i.extend([a, b, b + 1, a + 1])
    for base_y, top_y, r in ((0.25, 0.75, 0.45), (0.55, 1.0, 0.3)):  # crown
        apex = len(p)
        p.append((0.0, top_y, 0.0))
        for s in range(segments):
            t = 2 * math.pi * s / segments
            p.append((r * math.cos(t), base_y, r * math.sin(t)))
        for s in range(segments):
            c.append(3)
            i.extend([apex, apex + 1 + (s + 1) % segments, apex + 1 + s])
    return mesh(stage, path, p, c, i, mat)


# Expected surface (m^2) of one instance, for sizing: close to the meshes'
# areas (the same formulas as below), good to a few percent.
def city_instance(rng):
    kind = rng.choices([0, 1, 2], weights=[6, 2, 2])[0]
    w, d = rng.uniform(4, 9), rng.uniform(4, 9)
    h = {0: rng.uniform(4, 60), 1: rng.uniform(4, 10), 2: rng.uniform(3, 8)}[kind]
    if kind == 0:
        area = w * d + 2 * h * (w + d)
        scale = (w, h, d)
    elif kind == 1:
        area = 2 * math.pi * (0.5 * w) * (0.5 * d) + math.pi * w * 0.6 * h
        scale = (w, h, d)
    else:
        area = math.pi * 0.2 * w * math.hypot(0.2 * w, h)
        scale = (w * 0.5, h, w * 0.5)
    return kind, scale, area


def forest_instance(rng):
    kind = rng.choices([0, 1], weights=[9, 1])[0]
    if kind == 0:  # pine, 4..25 m
        h = rng.uniform(4, 25)
        w = h * rng.uniform(0.35, 0.6)
        r1, r2 = 0.45 * w, 0.3 * w
        area = (math.pi * r1 * math.hypot(r1, 0.5 * h) + math.pi * r2 * math.hypot(r2, 0.45 * h)
                + 2 * math.pi * 0.08 * w * 0.3 * h)
        return 3, (w, h, w), area
    w, d, h = rng.uniform(0.5, 3), rng.uniform(0.5, 3), rng.uniform(0.3, 1.5)  # rock: a low tower
    return 0, (w, h, d), w * d + 2 * h * (w + d)


def write_district(path, kind, cells, seed, mats_colors):
    """One district layer: /District with its materials, prototypes and a
    PointInstancer over `cells` ((x, z) cell centres). Returns its area."""
    rng = random.Random(seed)
    stage = Usd.Stage.CreateNew(path)
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y)
    UsdGeom.SetStageMetersPerUnit(stage, 1.0)
    root = UsdGeom.Xform.Define(stage, "/District")
    stage.SetDefaultPrim(root.GetPrim())
    mats = [material(stage, f"/District/Looks/M{k}", col) for k, col in enumerate(mats_colors)]
    inst = UsdGeom.PointInstancer.Define(stage, "/District/Instances")
    UsdGeom.Scope.Define(stage, "/District/Instances/Prototypes")
    tower(stage, "/District/Instances/Prototypes/Tower", mats[0])
    dome(stage, "/District/Instances/Prototypes/Dome", mats[1])
    cone(stage, "/District/Instances/Prototypes/Tree", mats[3])
    pine(stage, "/District/Instances/Prototypes/Pine", mats[3])
    inst.CreatePrototypesRel().SetTargets([Sdf.Path(f"/District/Instances/Prototypes/{n}")
                                           for n in ("Tower", "Dome", "Tree", "Pine")])
    positions, scales, orients, ids = [], [], [], []
    area = 0.0
    per_cell = 1 if kind == "city" else 6
    for (x, z) in cells:
        for _ in range(per_cell):
            if kind == "city":
                k, scale, a = city_instance(rng)
                px, pz = x, z
            else:
                k, scale, a = forest_instance(rng)
                px, pz = x + rng.uniform(-0.5, 0.5) * CELL, z + rng.uniform(-0.5, 0.5) * CELL
            positions.append(Gf.Vec3f(px, 0, pz))
            scales.append(Gf.Vec3f(*scale))
            angle = rng.uniform(0, math.pi / 2)
            orients.append(Gf.Quath(math.cos(angle / 2), 0, math.sin(angle / 2), 0))
            ids.append(k)
            area += a
    inst.CreatePositionsAttr(Vt.Vec3fArray(positions))
    inst.CreateScalesAttr(Vt.Vec3fArray(scales))
    inst.CreateOrientationsAttr(Vt.QuathArray(orients))
    inst.CreateProtoIndicesAttr(Vt.IntArray(ids))
    stage.GetRootLayer().Save()
    return area, len(positions)


def write_asset(path, triangles, seed, color, subdivision=False):
    """One asset layer: /Asset (defaultPrim) with a material and one mesh of
    `triangles` triangles (rounded to an even grid): a torus (major radius 1,
    minor 0.35, so closed and without degenerate poles) displaced along its
    normal. subdivision: the same grid as a Catmull-Clark cage of
    triangles / 2 quads instead (a dense cage, as DCCs export smooth
    assets). Returns (triangles or cage faces written, area estimate in
    m^2)."""
    import numpy as np
    rng = np.random.default_rng(seed)
    quads = max(1, triangles // 2)
    seg = max(3, int(round(math.sqrt(quads * 2.857))))  # around the major circle (R/r ~ 2.857)
    ring = max(3, quads // seg)                         # around the tube
    u = np.arange(seg) * (2 * math.pi / seg)
    v = np.arange(ring) * (2 * math.pi / ring)
    uu, vv = np.meshgrid(u, v, indexing="ij")           # (seg, ring)
    disp = np.zeros_like(uu)
    for _ in range(6):  # a few random waves; amplitude small next to the tube radius
        a, b = rng.integers(1, 12), rng.integers(1, 8)
        disp += rng.uniform(0.005, 0.03) * np.sin(a * uu + b * vv + rng.uniform(0, 2 * math.pi))
    r = 0.35 + disp
    x = (1.0 + r * np.cos(vv)) * np.cos(uu)
    z = (1.0 + r * np.cos(vv)) * np.sin(uu)
    y = r * np.sin(vv) + 0.6
    points = np.stack([x, y, z], axis=-1).reshape(-1, 3).astype(np.float32)
    i = np.arange(seg)[:, None]
    j = np.arange(ring)[None, :]
    a_ = i * ring + j
    b_ = ((i + 1) % seg) * ring + j
    c_ = ((i + 1) % seg) * ring + (j + 1) % ring
    d_ = i * ring + (j + 1) % ring
    # Two triangles per quad, wound so that the normal points out of the tube.
    tris = np.stack([np.stack([a_, d_, c_], -1), np.stack([a_, c_, b_], -1)], axis=2)
    indices = tris.reshape(-1).astype(np.int32)
    count = indices.size // 3
    if subdivision:  # the quads themselves, wound as the triangles are
        indices = np.stack([a_, d_, c_, b_], -1).reshape(-1).astype(np.int32)
        count = indices.size // 4

    stage = Usd.Stage.CreateNew(path)
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y)
    UsdGeom.SetStageMetersPerUnit(stage, 1.0)
    root = UsdGeom.Xform.Define(stage, "/Asset")
    stage.SetDefaultPrim(root.GetPrim())
    mat = material(stage, "/Asset/Looks/M", color)
    m = UsdGeom.Mesh.Define(stage, "/Asset/Body")
    m.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.catmullClark if subdivision else UsdGeom.Tokens.none)
    m.CreateOrientationAttr(UsdGeom.Tokens.rightHanded)
    m.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(points))
    m.CreateFaceVertexCountsAttr(Vt.IntArray.FromNumpy(np.full(count, 4 if subdivision else 3,
                                                               dtype=np.int32)))
    m.CreateFaceVertexIndicesAttr(Vt.IntArray.FromNumpy(indices))
    lo, hi = points.min(axis=0), points.max(axis=0)
    m.CreateExtentAttr(Vt.Vec3fArray([Gf.Vec3f(*map(float, lo)), Gf.Vec3f(*map(float, hi))]))
    UsdShade.MaterialBindingAPI.Apply(m.GetPrim()).Bind(mat)
    stage.GetRootLayer().Save()
    return count, 4 * math.pi ** 2 * 1.0 * 0.35


ASSET_PITCH = 3.0  # metres between asset centres (each is ~2.7 m across)


def assets_ground_size(assets):
    return math.ceil(math.sqrt(assets)) * ASSET_PITCH


def write_assets_scene(a, stage, out_dir, stem, colors):
    """--kind assets: the asset layers and their payload prims. Returns
    (area in m^2, triangles)."""
    per_side = math.ceil(math.sqrt(a.assets))
    pitch = ASSET_PITCH
    UsdGeom.Scope.Define(stage, "/World/Assets")
    os.makedirs(os.path.join(out_dir, stem + "_assets"), exist_ok=True)
    per_asset = int(a.triangles // a.assets)
    area, triangles = 0.0, 0
    for k in range(a.assets):
        layer = f"{stem}_assets/a{k:04d}.usdc"
        t, ar = write_asset(os.path.join(out_dir, layer), per_asset, a.seed * 7919 + k, colors[k % 4],
                            a.subdivision)
        triangles += t
        area += ar
        prim = stage.DefinePrim(f"/World/Assets/A{k:04d}", "Xform")
        prim.GetPayloads().AddPayload(f"./{layer}")
        UsdGeom.Xformable(prim).AddTranslateOp().Set(
            Gf.Vec3d((k % per_side + 0.5) * pitch, 0.0, (k // per_side + 0.5) * pitch))
    return area, triangles


INSTANCE_PITCH = 3.0  # metres between instance centres (the torus is ~2.7 m across)


def write_instances_scene(a, stage, out_dir, stem, colors):
    """--kind instances: one prototype layer, --instances references to it.
    Returns (area in m^2, triangles with instances expanded)."""
    layer = f"{stem}_prototype.usdc"
    per, proto_area = write_asset(os.path.join(out_dir, layer), a.proto_triangles, a.seed, colors[1])
    per_side = math.ceil(math.sqrt(a.instances))
    rng = random.Random(a.seed)
    UsdGeom.Scope.Define(stage, "/World/Instances")
    for k in range(a.instances):
        prim = stage.DefinePrim(f"/World/Instances/I{k:05d}", "Xform")
        prim.GetReferences().AddReference(f"./{layer}")
        prim.SetInstanceable(not a.flatten)
        xf = UsdGeom.Xformable(prim)
        xf.AddTranslateOp().Set(Gf.Vec3d((k % per_side + 0.5) * INSTANCE_PITCH, 0.0,
                                         (k // per_side + 0.5) * INSTANCE_PITCH))
        xf.AddRotateYOp().Set(rng.uniform(0.0, 360.0))
        xf.AddScaleOp().Set(Gf.Vec3f(rng.uniform(0.8, 1.1)))
    return proto_area * a.instances, per * a.instances


def cells_for(kind, surfels, spacing, seed):
    """Cells per side so that the expected area holds `surfels` at `spacing`."""
    rng = random.Random(seed + 99)
    sample = city_instance if kind == "city" else forest_instance
    per_cell = 1 if kind == "city" else 6
    mean = sum(sample(rng)[2] for _ in range(4000)) / 4000.0
    area_per_cell = CELL * CELL + per_cell * mean
    return max(1, math.ceil(math.sqrt(surfels * spacing * spacing / area_per_cell)))


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--kind", choices=["city", "forest", "assets", "instances"], default="city")
    ap.add_argument("--instances", type=int, default=10000,
                    help="instances of the one prototype, --kind instances (default 10000)")
    ap.add_argument("--proto-triangles", type=int, default=20000,
                    help="triangles of the prototype, --kind instances (default 20000)")
    ap.add_argument("--flatten", action="store_true",
                    help="--kind instances: the same prims without instanceable (flattened)")
    ap.add_argument("--assets", type=int, default=200, help="assets of --kind assets (default 200)")
    ap.add_argument("--subdivision", action="store_true",
                    help="--kind assets: each asset a Catmull-Clark cage of --triangles / --assets / 2 "
                         "quads instead of triangles")
    ap.add_argument("--triangles", type=float, default=20e6,
                    help="triangles of all assets together, --kind assets (default 2e7)")
    ap.add_argument("--surfels", type=float, default=100e6,
                    help="surfels the scene should hold at --spacing (default 1e8)")
    ap.add_argument("--spacing", type=float, default=0.05,
                    help="surfel spacing in metres the size is computed for (default 0.05)")
    ap.add_argument("--blocks", type=int, default=0, help="cells per side (overrides --surfels)")
    ap.add_argument("--district", type=int, default=8, help="cells per side of one payload (default 8)")
    ap.add_argument("--ground-tiles", type=int, default=64, help="ground quads per side (default 64)")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--out", required=True, help="output .usda/.usdc (district layers go next to it)")
    a = ap.parse_args()
    if a.kind == "assets" and (a.assets < 1 or a.triangles < 2 * a.assets):
        ap.error("--assets must be >= 1 and --triangles >= 2 per asset")
    if a.kind == "instances" and (a.instances < 1 or a.proto_triangles < 2):
        ap.error("--instances must be >= 1 and --proto-triangles >= 2")
    blocks = 0 if a.kind in ("assets", "instances") else a.blocks or cells_for(a.kind, a.surfels, a.spacing, a.seed)
    out_dir = os.path.dirname(os.path.abspath(a.out))
    os.makedirs(out_dir, exist_ok=True)
    stem = os.path.splitext(os.path.basename(a.out))[0]

    stage = Usd.Stage.CreateNew(a.out)
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y)
    UsdGeom.SetStageMetersPerUnit(stage, 1.0)
    world = UsdGeom.Xform.Define(stage, "/World")
    stage.SetDefaultPrim(world.GetPrim())
    colors = [(0.55, 0.52, 0.48), (0.7, 0.35, 0.25), (0.3, 0.45, 0.6), (0.2, 0.5, 0.2), (0.4, 0.4, 0.42)]
    ground_mat = material(stage, "/World/Looks/Ground", colors[4])

    if a.kind == "assets":
        size = assets_ground_size(a.assets)
    elif a.kind == "instances":
        size = math.ceil(math.sqrt(a.instances)) * INSTANCE_PITCH
    else:
        size = blocks * CELL
    p, c, i = [], [], []
    grid_quad((0, 0, size), (size, 0, 0), (0, 0, -size), a.ground_tiles, p, c, i)  # +y
    mesh(stage, "/World/Ground", p, c, i, ground_mat)
    area = size * size

    if a.kind == "assets":
        a_area, triangles = write_assets_scene(a, stage, out_dir, stem, colors)
        area += a_area
        summary = (f"{a.assets} payload assets, {triangles} "
                   f"{'Catmull-Clark cage quads' if a.subdivision else 'triangles'}")
    elif a.kind == "instances":
        i_area, triangles = write_instances_scene(a, stage, out_dir, stem, colors)
        area += i_area
        summary = (f"{a.instances} {'flattened' if a.flatten else 'instanceable'} references to one "
                   f"prototype of {triangles // a.instances} triangles ({triangles} expanded)")
    else:

        # Districts: one layer each, payloaded under /World/Districts.
        UsdGeom.Scope.Define(stage, "/World/Districts")
        instances = 0
        n_districts = math.ceil(blocks / a.district)
        for dx in range(n_districts):
            for dz in range(n_districts):
                cells = [((bx + 0.5) * CELL, (bz + 0.5) * CELL)
                         for bx in range(dx * a.district, min(blocks, (dx + 1) * a.district))
                         for bz in range(dz * a.district, min(blocks, (dz + 1) * a.district))]
                layer = f"{stem}_d{dx:03d}_{dz:03d}.usdc"
                d_area, d_inst = write_district(os.path.join(out_dir, layer), a.kind, cells,
                                                a.seed * 100003 + dx * 1009 + dz, colors)
                area += d_area
                instances += d_inst
                prim = stage.DefinePrim(f"/World/Districts/D{dx:03d}_{dz:03d}", "Xform")
                prim.GetPayloads().AddPayload(f"./{layer}")
        summary = (f"{blocks}x{blocks} cells in {n_districts ** 2} payload districts, "
                   f"{instances} instances")

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
    # In the street between the first two columns of cells, just outside the
    # last row (every cell holds a building; inside one, a renderer sees
    # only the building's back faces), looking into the street along -z.
    xf.AddTranslateOp().Set(Gf.Vec3d(CELL, 1.7, size + 0.25 * CELL))
    xf.AddRotateYOp().Set(-10.0)  # a little to +x, so the street's right side fills half the view

    stage.GetRootLayer().Save()
    print(f"{a.out}: {a.kind}, {summary} over {size:.0f} m, about {area:.4g} m^2 of surface: "
          f"{area / a.spacing ** 2:.3g} surfels at spacing {a.spacing} m "
          f"(build with --surfel-spacing {a.spacing})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
