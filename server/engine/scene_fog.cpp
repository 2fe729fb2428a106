#include "server/engine/scene_fog.h"

#include "server/volumes/fog_field.h"
#include "server/volumes/fog_points.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

namespace pbgi {

void prepare_fog(SceneSession& session, float spacing, const FogOptions& options) {
  auto field = std::make_shared<FogField>(*session.scene, options);
  if (field->empty()) return;
  // The page set depends on the fog (surfels are shaded through it).
  session.scene->content_hash += fmt::format("+fog/1(sigma={},albedo={},{},{},step={},samples={},block={})",
                                             options.extinction_per_density, options.albedo.x, options.albedo.y,
                                             options.albedo.z, options.step_voxels, options.light_samples,
                                             options.max_block_voxels);
  session.rays->set_medium(field);
  FogPointStats stats;
  auto points = std::make_shared<VolumePoints>(bake_fog_points(*session.scene, spacing, options, &stats));
  light_fog_points(*session.rays, *field, options, *points);
  spdlog::info("fog of '{}': {} grids, {} active voxels -> {} volume points of {} voxels ({} bytes)",
               session.scene->source_path, field->grid_count(), stats.active_voxels, stats.points,
               stats.block_voxels, points->memory_bytes());
  session.fog = std::move(points);
}

}  // namespace pbgi
