// Loads the image files a decoded Scene names -- UsdUVTexture files of
// materials and DomeLight lat-long maps -- with OpenImageIO (PNG, JPEG,
// OpenEXR, Radiance HDR, TIFF, ...) and converts their colours to the
// linear rendering space (lin_rec709) with OpenColorIO.
//
// Colour spaces (UsdUVTexture sourceColorSpace): "raw" is used as stored;
// "sRGB" goes through the config's srgb_texture colour space (the sRGB
// transfer function) to its scene_linear role, alpha untouched; "auto" is
// sRGB for 8-bit images with 3 or 4 channels unless OpenImageIO reads
// linear colour-space metadata from the file, and raw otherwise (float
// images, single channels): what Hydra Storm and MoonRay do. Dome maps are
// colour: float files are linear, 8-bit ones sRGB.
//
// Wrap modes left at useMetadata take the file's "wrapmodes" metadata
// (written by maketx/txmake) and are repeat without it.
//
// Each file is read once per colour space; copies of the bindings share
// it. A file that cannot be read costs a warning in Scene::warnings naming
// the material or light and the file; the binding stays unloaded, so the
// constant colour the reader sent (the texture's fallback, or grey) is
// used. A dome without its map keeps its constant radiance. Not
// thread-safe; run once per scene.
//
// Confinement: with TextureLoadOptions::roots confined, every file is
// checked before any is read; one outside the roots throws PermissionDenied
// naming the material or light (never the file).
#pragma once

#include "server/scene/asset_roots.h"
#include "server/scene/scene.h"

#include <memory>
#include <string>

namespace pbgi {

struct TextureLoadOptions {
  // OpenColorIO config; "" = $PBGI_OCIO_CONFIG if set, else the source
  // tree's config/ocio/config.ocio. Without a usable config (or without
  // srgb_texture and scene_linear in it) the sRGB decode is built in code
  // from the same OCIO transform, with a warning.
  std::string ocio_config;
  // Directories the image files must lie below (default: anywhere).
  AssetRoots roots;
};

void load_scene_textures(Scene& scene, const TextureLoadOptions& options = {});

}  // namespace pbgi
