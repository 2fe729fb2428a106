// Where a tile gathers when it interpolates (RenderOptions::interpolation):
// irradiance caching on the image plane (Ward 1988; the "gather every n-th
// pixel, interpolate under normal and depth checks" of production AO
// passes). A gather costs 0.4-0.7 ms of CPU; a camera ray with its shadow
// rays a few microseconds. So the tile gathers on a lattice of pixel centres
// anchored at the image's origin, coarse where the picture is smooth and
// refined where it is not, and every camera sample takes its irradiance, AO
// and bent normal from the lattice points around it.
//
// The lattice is a quadtree of square cells: a cell of side s has its
// corners at the pixel centres (x0, y0) .. (x0 + s, y0 + s) (clamped to the
// image). A cell is split into four while s > 1 and
//   - a camera sample inside it may take no corner's value
//     (may_interpolate(): another mesh, a normal turned by more than ~18
//     degrees, or off the corner's tangent plane: a depth step), or only
//     one corner's while the cell is wider than 4 pixels, or
//   - the corners a sample may take values from disagree by more than the
//     tolerance (corners_disagree()).
// A sample then takes the bilinear mix of the corners of its smallest cell
// that it may take values from; a sample that may take none (at s = 1,
// across an edge inside a pixel) and a sample with a glossy lobe (its gather
// depends on the view) get a gather of their own. Decisions read only the
// cell's own samples and corners, all placed at absolute pixel positions,
// so an image is the same whatever its split into tiles.
#pragma once

#include "server/gather/gather.h"
#include "server/gather/result_mix.h"  // mix_results: how samples take corners' values
#include "server/render/camera_sample.h"
#include "server/render/render_options.h"

#include <array>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>

namespace pbgi {

// May camera sample `s` take the gathered value of lattice point `corner`?
// Both on a surface of the same mesh, normals within ~18 degrees, and s
// near corner's tangent plane (relative to their distance).
bool may_interpolate(const SurfaceSample& s, const SurfaceSample& corner);

// Do these corner gathers of a cell (those a sample may take values from)
// disagree by more than `tolerance`: a luminance off their mean by more than
// tolerance x the mean, or an AO off by more than tolerance?
bool corners_disagree(std::span<const GatherResult* const> corners, float tolerance);

}  // namespace pbgi
