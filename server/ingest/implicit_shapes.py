"""Tessellation of UsdGeom's implicit surfaces into local-space triangles.

Sphere, Capsule, Cylinder and Cone (and their *_1 variants with separate top
and bottom radii) are surfaces of revolution around the prim's `axis`; they
are built by one lathe from a profile of rings. Cube and Plane are quads.
All triangles are wound counter-clockwise seen from outside (outward
right-handed normals); per-vertex normals are exact for the smooth parts and
duplicated across creases.
"""
import math

import numpy as np
from pxr import UsdGeom

# Segments around the axis and per quarter circle of a sphere/capsule cap:
# under 0.2 % area error, a few thousand triangles per shape.
_AROUND = 64
_QUARTER = 12


def _get(prim, name, time):
    return prim.GetAttribute(name).Get(time)


def _axis_frame(axis):
    """Maps the lathe's local frame (axis = +z) to the prim's axis with a
    cyclic permutation of coordinates, which keeps handedness (winding)."""
    return {"X": [2, 0, 1], "Y": [1, 2, 0], "Z": [0, 1, 2]}[axis]


def _lathe(rings, axis):
    """rings: list of (radius, height, normal_radial, normal_axial), bottom to
    top along the outside of the profile. Returns (points, triangles, normals)."""
    phi = np.linspace(0.0, 2.0 * math.pi, _AROUND, endpoint=False)
    c, s = np.cos(phi), np.sin(phi)
    points, normals = [], []
    for r, z, nr, nz in rings:
        points.append(np.stack([r * c, r * s, np.full_like(c, z)], axis=1))
        normals.append(np.stack([nr * c, nr * s, np.full_like(c, nz)], axis=1))
    points = np.concatenate(points)
    normals = np.concatenate(normals)
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)

    i = np.arange(_AROUND)
    j = (i + 1) % _AROUND
    triangles = []
    for ring in range(len(rings) - 1):
        lo, hi = ring * _AROUND, (ring + 1) * _AROUND
        a, b, c_, d = lo + i, lo + j, hi + j, hi + i
        same = np.isclose(rings[ring][:2], rings[ring + 1][:2]).all()
        if same:  # a crease: two rings at one place, only normals differ
            continue
        # A ring of radius zero is a pole: keep only the triangle that is not
        # degenerate (its per-segment copies keep the normals smooth).
        if rings[ring][0] > 0.0:
            triangles.append(np.stack([a, b, c_], axis=1))
        if rings[ring + 1][0] > 0.0:
            triangles.append(np.stack([a, c_, d], axis=1))
    triangles = np.concatenate(triangles) if triangles else np.zeros((0, 3), np.int64)
    perm = _axis_frame(axis)
    return points[:, perm], triangles, normals[:, perm]


def _arc(radius, center_z, a0, a1, steps):
    """Rings of a circular arc from angle a0 to a1 (radians above the equator)."""
    rings = []
    for t in np.linspace(a0, a1, steps + 1):
        c = math.cos(t)
        c = 0.0 if abs(c) < 1e-9 else c  # exact poles: see _lathe
        rings.append((radius * c, center_z + radius * math.sin(t), c, math.sin(t)))
    return rings


def _frustum(r_bottom, r_top, height):
    h = height / 2.0
    # Side normal of a frustum: radial 1, axial (rb - rt) / height.
    slope = (r_bottom - r_top) / height if height > 0 else 0.0
    rings = [(0.0, -h, 0.0, -1.0), (r_bottom, -h, 0.0, -1.0),
             (r_bottom, -h, 1.0, slope), (r_top, h, 1.0, slope)]
    if r_top > 0.0:
        rings += [(r_top, h, 0.0, 1.0), (0.0, h, 0.0, 1.0)]
    return rings


def _capsule(r_bottom, r_top, height):
    h = height / 2.0
    rings = _arc(r_bottom, -h, -math.pi / 2, 0.0, _QUARTER)
    rings += _arc(r_top, h, 0.0, math.pi / 2, _QUARTER)
    return rings


def _quads(corners, normal):
    points = np.asarray(corners, dtype=np.float64)
    n = np.cross(points[1] - points[0], points[2] - points[0])
    if np.dot(n, normal) < 0.0:
        points = points[::-1].copy()
    triangles = np.array([[0, 1, 2], [0, 2, 3]], dtype=np.int64)
    normals = np.tile(np.asarray(normal, dtype=np.float64), (4, 1))
    return points, triangles, normals


def _cube(size):
    h = size / 2.0
    points, triangles, normals = [], [], []
    for axis in range(3):
        for sign in (-1.0, 1.0):
            u, v = [k for k in range(3) if k != axis]
            corners = []
            for du, dv in ((-h, -h), (h, -h), (h, h), (-h, h)):
                p = [0.0, 0.0, 0.0]
                p[axis], p[u], p[v] = sign * h, du, dv
                corners.append(p)
            normal = [0.0, 0.0, 0.0]
            normal[axis] = sign
            p, t, n = _quads(corners, normal)
            triangles.append(t + 4 * len(points))
            points.append(p)
            normals.append(n)
    return np.concatenate(points), np.concatenate(triangles), np.concatenate(normals)


def _plane(width, length, axis):
    # Width/length axes per UsdGeomPlane: X -> (z, y), Y -> (x, z), Z -> (x, y).
    u, v, a = {"X": (2, 1, 0), "Y": (0, 2, 1), "Z": (0, 1, 2)}[axis]
    corners = []
    for du, dv in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
        p = [0.0, 0.0, 0.0]
        p[u], p[v] = du * width / 2.0, dv * length / 2.0
        corners.append(p)
    normal = [0.0, 0.0, 0.0]
    normal[a] = 1.0
    return _quads(corners, normal)


SUPPORTED = ("Sphere", "Cube", "Cylinder", "Cylinder_1", "Cone", "Capsule", "Capsule_1", "Plane")


def tessellate(prim, time):
    """Returns (points, triangles, normals) in the prim's local space, or None
    if the prim is not an implicit surface handled here."""
    kind = prim.GetTypeName()
    if kind == "Sphere":
        r = _get(prim, "radius", time)
        return _lathe(_arc(r, 0.0, -math.pi / 2, math.pi / 2, 2 * _QUARTER), "Z")
    if kind == "Cube":
        return _cube(_get(prim, "size", time))
    axis = _get(prim, "axis", time)
    if kind == "Cylinder":
        r = _get(prim, "radius", time)
        return _lathe(_frustum(r, r, _get(prim, "height", time)), axis)
    if kind == "Cylinder_1":
        return _lathe(_frustum(_get(prim, "radiusBottom", time), _get(prim, "radiusTop", time),
                               _get(prim, "height", time)), axis)
    if kind == "Cone":  # apex toward +axis
        return _lathe(_frustum(_get(prim, "radius", time), 0.0, _get(prim, "height", time)), axis)
    if kind == "Capsule":
        r = _get(prim, "radius", time)
        return _lathe(_capsule(r, r, _get(prim, "height", time)), axis)
    if kind == "Capsule_1":
        return _lathe(_capsule(_get(prim, "radiusBottom", time), _get(prim, "radiusTop", time),
                               _get(prim, "height", time)), axis)
    if kind == "Plane":
        return _plane(_get(prim, "width", time), _get(prim, "length", time), axis)
    return None


def is_implicit(prim):
    return prim.GetTypeName() in SUPPORTED and prim.IsA(UsdGeom.Gprim)
