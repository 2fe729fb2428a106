#!/usr/bin/env python3
"""Authors scenes/cornell.usda, pbgi's Cornell box, with Pixar's USD.

Run with the project's venv:  .venv/bin/python scenes/make_cornell.py
The .usda is committed; this script documents how it was derived (vertex
order, normals, light orientation) and checks those choices before writing.

Room: x in [-1, 1], y in [0, 2], z in [-1, 1], open on +z where the camera is.
Every Mesh has subdivisionScheme "none" (USD's default is catmullClark) and
right-handed winding whose normal points into the room (walls) or out of the
boxes; authored normals agree with the winding.
"""
import math
import os
import sys

from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux, UsdShade, Vt

# Albedos of the classic Cornell box (linear, from its measured spectra).
WHITE = (0.725, 0.71, 0.68)
RED = (0.63, 0.065, 0.05)
GREEN = (0.14, 0.45, 0.091)

# Rect light radiance (W / (sr m^2)); with 0.5 x 0.4 at y = 1.98 it gives the
# back wall centre a direct outgoing radiance of about 0.45 and the floor
# centre about 0.47 (see the estimate in check_exposure()).
LIGHT_INTENSITY = 40.0
LIGHT_SIZE = (0.5, 0.4)
LIGHT_HEIGHT = 1.98

# Camera: 40 degrees vertical field of view, square image.
FOCAL_LENGTH = 35.0
APERTURE = 2.0 * FOCAL_LENGTH * math.tan(math.radians(20.0))


def quad_normal(p):
    a, b, c = (Gf.Vec3d(*p[i]) for i in range(3))
    return Gf.GetNormalized(Gf.Cross(b - a, c - a))


def define_material(stage, path, color, roughness=1.0, metallic=0.0):
    material = UsdShade.Material.Define(stage, path)
    shader = UsdShade.Shader.Define(stage, path + "/PreviewSurface")
    shader.CreateIdAttr("UsdPreviewSurface")
    shader.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(*color))
    shader.CreateInput("roughness", Sdf.ValueTypeNames.Float).Set(roughness)
    shader.CreateInput("metallic", Sdf.ValueTypeNames.Float).Set(metallic)
    material.CreateSurfaceOutput().ConnectToSource(shader.ConnectableAPI(), "surface")
    return material


def define_mesh(stage, path, points, counts, indices, normals, interpolation, material):
    mesh = UsdGeom.Mesh.Define(stage, path)
    mesh.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.none)
    mesh.CreateOrientationAttr(UsdGeom.Tokens.rightHanded)
    mesh.CreatePointsAttr(Vt.Vec3fArray([Gf.Vec3f(*p) for p in points]))
    mesh.CreateFaceVertexCountsAttr(Vt.IntArray(counts))
    mesh.CreateFaceVertexIndicesAttr(Vt.IntArray(indices))
    mesh.CreateNormalsAttr(Vt.Vec3fArray([Gf.Vec3f(*n) for n in normals]))
    mesh.SetNormalsInterpolation(interpolation)
    mesh.CreateExtentAttr(UsdGeom.Mesh.ComputeExtent(mesh.GetPointsAttr().Get()))
    UsdShade.MaterialBindingAPI.Apply(mesh.GetPrim()).Bind(material)
    return mesh


def wall(stage, path, corners, inward, material):
    """One quad; corners are ordered so that their winding normal is `inward`."""
    n = quad_normal(corners)
    assert Gf.Dot(n, Gf.Vec3d(*inward)) > 0.999, (path, n, inward)
    return define_mesh(stage, path, corners, [4], [0, 1, 2, 3], [inward] * 4,
                       UsdGeom.Tokens.vertex, material)


def box(stage, path, size, translate, rotate_y, material):
    """Closed box centred on its local origin with outward winding."""
    hx, hy, hz = (s / 2.0 for s in size)
    points = [(-hx, -hy, -hz), (hx, -hy, -hz), (hx, hy, -hz), (-hx, hy, -hz),
              (-hx, -hy, hz), (hx, -hy, hz), (hx, hy, hz), (-hx, hy, hz)]
    faces = {  # outward normal -> corners (counter-clockwise seen from outside)
        (0, 0, 1): [4, 5, 6, 7],
        (0, 0, -1): [1, 0, 3, 2],
        (1, 0, 0): [5, 1, 2, 6],
        (-1, 0, 0): [0, 4, 7, 3],
        (0, 1, 0): [7, 6, 2, 3],
        (0, -1, 0): [0, 1, 5, 4],
    }
    indices, normals = [], []
    for outward, corners in faces.items():
        n = quad_normal([points[i] for i in corners])
        assert Gf.Dot(n, Gf.Vec3d(*outward)) > 0.999, (path, outward, n)
        indices += corners
        normals += [outward] * 4
    mesh = define_mesh(stage, path, points, [4] * 6, indices, normals,
                       UsdGeom.Tokens.faceVarying, material)
    mesh.AddTranslateOp().Set(Gf.Vec3d(*translate))
    mesh.AddRotateYOp().Set(rotate_y)
    return mesh


def check_exposure():
    """Direct outgoing radiance at the back-wall centre, by midpoint quadrature."""
    w, h = LIGHT_SIZE
    n = 64
    x = Gf.Vec3d(0.0, 1.0, -1.0)
    irradiance = 0.0
    for i in range(n):
        for j in range(n):
            p = Gf.Vec3d(-w / 2 + (i + 0.5) * w / n, LIGHT_HEIGHT, -h / 2 + (j + 0.5) * h / n)
            d = p - x
            r2 = Gf.Dot(d, d)
            cos_wall = d[2] / math.sqrt(r2)
            cos_light = d[1] / math.sqrt(r2)
            irradiance += LIGHT_INTENSITY * cos_wall * cos_light / r2 * (w * h / n / n)
    return WHITE[0] / math.pi * irradiance


def main(out_path, glossy=False):
    if os.path.exists(out_path):
        os.remove(out_path)  # CreateNew refuses to overwrite
    stage = Usd.Stage.CreateNew(out_path)
    stage.SetMetadata("comment", "pbgi Cornell box; generated by scenes/make_cornell.py")
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y)
    UsdGeom.SetStageMetersPerUnit(stage, 1.0)

    world = UsdGeom.Xform.Define(stage, "/World")
    stage.SetDefaultPrim(world.GetPrim())

    UsdGeom.Scope.Define(stage, "/World/Materials")
    white = define_material(stage, "/World/Materials/White", WHITE)
    red = define_material(stage, "/World/Materials/Red", RED)
    green = define_material(stage, "/World/Materials/Green", GREEN)
    # The glossy variant (cornell_gold.usda): a gold-like metal tall box,
    # a glossy sender that reflects the light onto the walls and floor.
    tall = define_material(stage, "/World/Materials/Gold", (0.95, 0.8, 0.45), roughness=0.15,
                           metallic=1.0) if glossy else white

    UsdGeom.Xform.Define(stage, "/World/Room")
    wall(stage, "/World/Room/Floor",
         [(-1, 0, -1), (-1, 0, 1), (1, 0, 1), (1, 0, -1)], (0, 1, 0), white)
    wall(stage, "/World/Room/Ceiling",
         [(-1, 2, -1), (1, 2, -1), (1, 2, 1), (-1, 2, 1)], (0, -1, 0), white)
    wall(stage, "/World/Room/BackWall",
         [(-1, 0, -1), (1, 0, -1), (1, 2, -1), (-1, 2, -1)], (0, 0, 1), white)
    wall(stage, "/World/Room/LeftWall",
         [(-1, 0, -1), (-1, 2, -1), (-1, 2, 1), (-1, 0, 1)], (1, 0, 0), red)
    wall(stage, "/World/Room/RightWall",
         [(1, 0, -1), (1, 0, 1), (1, 2, 1), (1, 2, -1)], (-1, 0, 0), green)

    box(stage, "/World/TallBox", (0.6, 1.2, 0.6), (-0.33, 0.6, -0.3), 15.0, tall)
    box(stage, "/World/ShortBox", (0.6, 0.6, 0.6), (0.33, 0.3, 0.35), -18.0, white)

    UsdGeom.Scope.Define(stage, "/Lights")
    light = UsdLux.RectLight.Define(stage, "/Lights/Ceiling")
    light.CreateWidthAttr(LIGHT_SIZE[0])
    light.CreateHeightAttr(LIGHT_SIZE[1])
    light.CreateIntensityAttr(LIGHT_INTENSITY)
    light.CreateExposureAttr(0.0)
    light.CreateColorAttr(Gf.Vec3f(1.0, 1.0, 1.0))
    light.CreateNormalizeAttr(False)
    light.AddTranslateOp().Set(Gf.Vec3d(0.0, LIGHT_HEIGHT, 0.0))
    # A RectLight emits toward its local -Z; rotating -90 degrees about X
    # turns -Z into world -Y (down), so the ceiling above gets no direct light.
    light.AddRotateXOp().Set(-90.0)
    down = light.ComputeLocalToWorldTransform(Usd.TimeCode.Default()).TransformDir(
        Gf.Vec3d(0, 0, -1))
    assert Gf.IsClose(down, Gf.Vec3d(0, -1, 0), 1e-9), down

    camera = UsdGeom.Camera.Define(stage, "/Camera")
    camera.CreateProjectionAttr(UsdGeom.Tokens.perspective)
    camera.CreateFocalLengthAttr(FOCAL_LENGTH)
    camera.CreateHorizontalApertureAttr(APERTURE)
    camera.CreateVerticalApertureAttr(APERTURE)
    camera.CreateClippingRangeAttr(Gf.Vec2f(0.1, 100.0))
    camera.AddTranslateOp().Set(Gf.Vec3d(0.0, 1.0, 3.4))

    stage.GetRootLayer().Save()
    print(f"wrote {out_path}; back wall direct radiance ~{check_exposure():.3f}", file=sys.stderr)


if __name__ == "__main__":
    here = os.path.dirname(os.path.abspath(__file__))
    glossy = "--glossy" in sys.argv[1:]
    args = [a for a in sys.argv[1:] if a != "--glossy"]
    default = "cornell_gold.usda" if glossy else "cornell.usda"
    main(args[0] if args else os.path.join(here, default), glossy)
