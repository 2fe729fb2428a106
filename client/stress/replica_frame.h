// One frame rendered over several pbgid replicas serving the same page set
// (content-addressed: the same scene and build options give the same
// scene_id on every replica). Tiles are dealt round robin on the client
// (tile i to replica i mod n), which is how a render farm spreads a frame
// over a headless Service's endpoints; a tile whose replica is unavailable
// fails over to the next replica.
#pragma once

#include "client/lib/frame_renderer.h"
#include "client/lib/pbgi_client.h"

#include <cstdint>
#include <vector>

namespace pbgi::stress {

struct ReplicaFrame {
  client::Frame frame;
  std::vector<uint32_t> tiles_per_replica;   // tiles each replica rendered
  uint32_t failovers = 0;                    // tiles moved off an unavailable replica
};

// `request.jobs` requests in flight in total (at least one per replica);
// request.scene_id is used on every replica. Throws InvalidArgument (no
// replica, empty image) and the first RpcError that is not UNAVAILABLE or
// that every replica returned.
ReplicaFrame render_frame_replicated(const std::vector<client::PbgiClient*>& replicas,
                                     const client::FrameRequest& request);

}  // namespace pbgi::stress
