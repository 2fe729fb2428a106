// The open scenes of the daemon. A scene is keyed by its canonical path and
// the options it is built with; the same key always gives the same session,
// and it is opened once even when several clients ask for it at the same
// time (the later callers wait for the first open and see its progress).
#pragma once

#include "server/engine/scene_session.h"

#include <cstdint>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <shared_mutex>
#include <string>
#include <unordered_map>
#include <vector>

namespace pbgi::service {

// Opens one scene (the engine's open_scene in the daemon; a fake in tests).
using SceneOpener = std::function<std::shared_ptr<SceneSession>(
    const std::filesystem::path& path, const OpenOptions& options, const StageProgress& progress)>;

// Thread-safe. Sessions stay open for the registry's lifetime (no eviction
// in this slice: their pages live in the shared, budgeted page cache), and a
// scene file edited after its open is not reopened until the daemon restarts.
class SceneRegistry {
 public:
  explicit SceneRegistry(SceneOpener opener);
  ~SceneRegistry();

  // Returns the session of (canonical_path, options), opening it if no
  // caller has yet. `progress` receives the stages of the open this call
  // runs or joins (possibly from other threads; calls are not concurrent).
  // A waiting caller polls `cancelled` and throws pbgi::Cancelled once it
  // returns true; the open itself goes on for the others. Errors of the
  // open are rethrown to every caller waiting for it and are not cached: a
  // later call tries again.
  std::shared_ptr<SceneSession> open(const std::filesystem::path& canonical_path,
                                     const OpenOptions& options,
                                     const StageProgress& progress = {},
                                     const std::function<bool()>& cancelled = {});

  // The open session with this scene_id, or nullptr.
  std::shared_ptr<SceneSession> find(const std::string& scene_id) const;

  // All open sessions, ordered by scene path.
  std::vector<std::shared_ptr<SceneSession>> list() const;

  // Number of opens started (for tests and metrics).
  uint64_t opens_started() const;

 private:
  struct Pending;

  SceneOpener opener_;
  mutable std::shared_mutex mutex_;
  std::map<std::string, std::shared_ptr<Pending>> by_key_;   // includes opens in flight
  std::unordered_map<std::string, std::shared_ptr<SceneSession>> by_id_;  // ready only
  uint64_t opens_started_ = 0;
};

}  // namespace pbgi::service
