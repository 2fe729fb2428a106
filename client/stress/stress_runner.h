// `pbgi stress`: N concurrent clients rendering random tiles of one camera
// through RenderTile for a fixed time, counting every outcome. Any non-OK
// status is an error of the run (a daemon under load must not fail
// requests); latencies are measured per call on the client.
#pragma once

#include "client/stress/latency_summary.h"
#include "pbgi/v1/pbgi.pb.h"

#include <chrono>
#include <cstdint>
#include <functional>
#include <map>
#include <string>
#include <vector>

namespace pbgi::stress {

struct StressOptions {
  // Daemon addresses; client i talks to servers[i % size] (client-side
  // round robin over replicas). At least one.
  std::vector<std::string> servers;
  std::string scene;                    // path as sent in OpenScene
  std::string camera;                   // "" = client::camera_for(): the only camera, or auto
  unsigned clients = 4;                 // concurrent clients, one request in flight each
  std::chrono::duration<double> duration{10.0};
  uint32_t width = 256, height = 256;   // image the random tiles are cut from
  uint32_t tile = 32;                   // tile side (edge tiles are smaller)
  v1::BuildOptions build;               // OpenScene options (unset: daemon defaults)
  v1::GatherOptions gather;             // RenderTile options (unset: daemon defaults)
  std::chrono::milliseconds call_deadline{60000};  // per RenderTile call
  // Attempts per call on UNAVAILABLE; 1 counts every UNAVAILABLE as an error.
  int max_attempts = 1;
  uint64_t seed = 1;                    // tile choice of client i uses seed + i
};

struct StressResult {
  std::vector<std::string> scene_ids;   // per server (equal for replicas of one page set)
  std::string camera;
  unsigned clients = 0;
  double seconds = 0;                   // wall clock of the load phase
  uint64_t requests = 0;                // calls finished (ok + errors)
  uint64_t ok = 0;
  uint64_t pixels = 0;                  // pixels of the successful tiles
  std::map<std::string, uint64_t> errors_by_code;  // "UNAVAILABLE" ...; "CLIENT" = bad response
  std::vector<std::string> error_samples;          // the first few error messages
  std::vector<uint64_t> requests_per_server;
  LatencySummary latency;               // of successful calls

  uint64_t errors() const { return requests - ok; }
  double throughput() const { return seconds > 0 ? ok / seconds : 0; }  // tiles per second
  bool passed() const { return errors() == 0 && ok > 0; }
};

// Called about once a second from the coordinating thread.
using StressProgress = std::function<void(double elapsed_seconds, uint64_t requests, uint64_t errors)>;

// Opens the scene on every server (throws RpcError / InvalidArgument if that
// fails: no load is generated then), runs the load for `duration`, and
// returns the counts. Errors during the load are counted, not thrown.
StressResult run_stress(const StressOptions& options, const StressProgress& progress = {});

}  // namespace pbgi::stress
