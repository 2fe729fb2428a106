#!/usr/bin/env python3
"""Authors scenes/cutout_test.usda: cut-out and partly transparent cards
casting shadows (server/scene/surface_opacity.h), and the opacity mask it
uses (scenes/textures/leaf_alpha.png).

Run with the project's venv:  .venv/bin/python scenes/make_cutout_test.py
The .usda and the image are committed; this script documents how they were
derived. The PNG is written without an imaging library (zlib + CRC framing).

Y up, 1 unit = 1 m. Under /World:

- Ground  a white (0.8) 2 x 2 quad at y = 0.
- Leaf    a 0.6 x 0.6 green card at y = 0.6, x in [-0.9, -0.3], z in
          [-0.7, -0.1], double-sided, whose opacity reads the alpha of
          textures/leaf_alpha.png (a leaf: an ellipse with a midrib and four
          slits cut across it) with opacityThreshold 0.5: a cutout.
- Veil    a 0.6 x 0.6 grey card beside it (z in [0.1, 0.7]) with constant
          opacity 0.5 and no threshold: fractional opacity.
- Sun     a DistantLight 45 degrees from the zenith towards +x, so each card's
          shadow falls 0.6 to its right, on x in [-0.3, 0.3].
- Camera  3 m above the origin looking straight down, framing the ground.
"""
import math
import os

from png_file import write_png
from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux, UsdShade, Vt

HERE = os.path.dirname(os.path.abspath(__file__))
MASK = 64


def leaf_alpha(s, t):
    """1 on the leaf, 0 in its holes and around it; (s, t) in [0, 1]^2, the
    leaf's midrib along s."""
    x, y = 2.0 * s - 1.0, 2.0 * t - 1.0
    if x * x / 0.95 ** 2 + y * y / 0.7 ** 2 >= 1.0:
        return 0
    if abs(y) < 0.12:  # the midrib
        return 1
    slit = int(math.floor((x + 1.0) * 4.0))  # four slits across, every other band
    return 0 if slit % 2 == 1 and abs(y) > 0.2 else 1


def write_mask(path):
    pixels = []
    for row in range(MASK):
        t = 1.0 - (row + 0.5) / MASK  # PNG rows top down, t up
        for col in range(MASK):
            a = 255 * leaf_alpha((col + 0.5) / MASK, t)
            pixels += [40, 150, 40, a]
    write_png(path, MASK, MASK, pixels, channels=4)


def quad(stage, path, x0, x1, y, z0, z1, st=False):
    mesh = UsdGeom.Mesh.Define(stage, path)
    mesh.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.none)
    # Counter-clockwise seen from above (+y): normal up.
    mesh.CreatePointsAttr(Vt.Vec3fArray([Gf.Vec3f(x0, y, z1), Gf.Vec3f(x1, y, z1),
                                         Gf.Vec3f(x1, y, z0), Gf.Vec3f(x0, y, z0)]))
    mesh.CreateFaceVertexCountsAttr([4])
    mesh.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    mesh.CreateNormalsAttr(Vt.Vec3fArray([Gf.Vec3f(0, 1, 0)] * 4))
    mesh.SetNormalsInterpolation(UsdGeom.Tokens.vertex)
    mesh.CreateExtentAttr([Gf.Vec3f(x0, y, z0), Gf.Vec3f(x1, y, z1)])
    if st:
        primvar = UsdGeom.PrimvarsAPI(mesh).CreatePrimvar(
            "st", Sdf.ValueTypeNames.TexCoord2fArray, UsdGeom.Tokens.vertex)
        primvar.Set(Vt.Vec2fArray([Gf.Vec2f(0, 0), Gf.Vec2f(1, 0), Gf.Vec2f(1, 1), Gf.Vec2f(0, 1)]))
    return mesh


def surface(stage, path, color):
    material = UsdShade.Material.Define(stage, path)
    shader = UsdShade.Shader.Define(stage, path + "/Surface")
    shader.CreateIdAttr("UsdPreviewSurface")
    shader.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(*color))
    shader.CreateInput("roughness", Sdf.ValueTypeNames.Float).Set(1.0)
    material.CreateSurfaceOutput().ConnectToSource(shader.ConnectableAPI(), "surface")
    return material, shader


def bind(mesh, material):
    UsdShade.MaterialBindingAPI.Apply(mesh.GetPrim()).Bind(material)


def main():
    write_mask(os.path.join(HERE, "textures", "leaf_alpha.png"))
    path = os.path.join(HERE, "cutout_test.usda")
    stage = Usd.Stage.CreateNew(path)
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y)
    UsdGeom.SetStageMetersPerUnit(stage, 1.0)
    stage.SetDefaultPrim(UsdGeom.Xform.Define(stage, "/World").GetPrim())

    ground = quad(stage, "/World/Ground", -1.0, 1.0, 0.0, -1.0, 1.0)
    white, _ = surface(stage, "/World/Materials/White", (0.8, 0.8, 0.8))
    bind(ground, white)

    leaf = quad(stage, "/World/Leaf", -0.9, -0.3, 0.6, -0.7, -0.1, st=True)
    leaf.CreateDoubleSidedAttr(True)
    green, shader = surface(stage, "/World/Materials/Leaf", (0.2, 0.55, 0.15))
    shader.CreateInput("opacityThreshold", Sdf.ValueTypeNames.Float).Set(0.5)
    reader = UsdShade.Shader.Define(stage, "/World/Materials/Leaf/St")
    reader.CreateIdAttr("UsdPrimvarReader_float2")
    reader.CreateInput("varname", Sdf.ValueTypeNames.String).Set("st")
    reader.CreateOutput("result", Sdf.ValueTypeNames.Float2)
    texture = UsdShade.Shader.Define(stage, "/World/Materials/Leaf/Mask")
    texture.CreateIdAttr("UsdUVTexture")
    texture.CreateInput("file", Sdf.ValueTypeNames.Asset).Set("./textures/leaf_alpha.png")
    texture.CreateInput("sourceColorSpace", Sdf.ValueTypeNames.Token).Set("raw")
    texture.CreateInput("st", Sdf.ValueTypeNames.Float2).ConnectToSource(
        reader.ConnectableAPI(), "result")
    texture.CreateOutput("a", Sdf.ValueTypeNames.Float)
    shader.CreateInput("opacity", Sdf.ValueTypeNames.Float).ConnectToSource(
        texture.ConnectableAPI(), "a")
    bind(leaf, green)

    veil = quad(stage, "/World/Veil", -0.9, -0.3, 0.6, 0.1, 0.7)
    veil.CreateDoubleSidedAttr(True)
    grey, shader = surface(stage, "/World/Materials/Veil", (0.5, 0.5, 0.5))
    shader.CreateInput("opacity", Sdf.ValueTypeNames.Float).Set(0.5)
    bind(veil, grey)

    sun = UsdLux.DistantLight.Define(stage, "/World/Sun")
    sun.CreateIntensityAttr(3.0)
    sun.CreateAngleAttr(0.53)
    # The light shines down its -Z: first pointed down (-90 about X), then
    # tilted 45 degrees about Z towards +x.
    xf = UsdGeom.Xformable(sun)
    xf.AddRotateZOp().Set(45.0)
    xf.AddRotateXOp().Set(-90.0)

    camera = UsdGeom.Camera.Define(stage, "/World/Camera")
    camera.CreateFocalLengthAttr(55.0)
    camera.CreateHorizontalApertureAttr(40.0)
    camera.CreateVerticalApertureAttr(40.0)
    cam = UsdGeom.Xformable(camera)
    cam.AddTranslateOp().Set(Gf.Vec3d(0, 3, 0))
    cam.AddRotateXOp().Set(-90.0)

    stage.GetRootLayer().Save()


if __name__ == "__main__":
    main()
