// The memory a scene holds while it is read, told before it is allocated
// to whoever bounds it (the daemon's memory budget charges it:
// server/engine/memory_accountant.h, ChargeKind::kRead).
//
// The stream decoder (scene_stream_decoder.h) calls it with the bytes its
// scene will hold -- the geometry's capacity as Scene::geometry_bytes()
// counts it, plus the buffers about to be allocated while the old ones
// still exist -- before each chunk's arrays grow, and again with what the
// scene holds once they are in place. `what` names the growth: the frame,
// its byte offset and the prim ("scene geometry being read: frame 812 at
// byte offset 90817262, MeshChunk of /World/asset_3/mesh").
//
// The function may throw (ResourceExhausted) to refuse a growth: the read
// stops, nothing more is allocated, the exception propagates to the
// caller of the read, and the reader process (if any) is stopped. The
// value it gets last is what the returned Scene's geometry holds.
//
// Not counted here (the caller's stated overhead): one frame's bytes and
// its parsed chunk, one subdivision surface's refinement before it is
// appended, textures and fog grids.
#pragma once

#include <cstdint>
#include <functional>
#include <string>

namespace pbgi {

using SceneReadMemory = std::function<void(uint64_t bytes, const std::string& what)>;

}  // namespace pbgi
