// The open scenes of the daemon. A scene is keyed by its canonical path,
// the options it is built with and its stage selection (variants, time
// code); the same key always gives the same session, and it is opened once
// even when several clients ask for it at the same time (the later callers
// wait for the first open and see its progress).
//
// Cancellation: an open in flight goes on while any of its callers is still
// there, and is cancelled (the opener's `cancelled` turns true; it stops
// and removes what it staged) once every one of them has left: a
// disconnect, a deadline, the daemon's shutdown. A caller without a
// `cancelled` callback (the daemon's --preload) never leaves.
//
// Memory: a session's pages live in the shared, budgeted page cache; its
// geometry and ray-tracing structure are charged to the daemon's memory
// accountant (server/engine/memory_accountant.h), which calls
// unload_idle() when a new charge does not fit. With a scene memory budget
// (a sub-limit on the sessions' total alone), opening a scene that takes
// the sessions' total over it unloads the least recently used other
// sessions (requests already holding one finish normally: sessions are
// shared_ptrs).
#pragma once

#include "server/engine/scene_session.h"

#include <chrono>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <shared_mutex>
#include <string>
#include <unordered_map>
#include <vector>

namespace pbgi::service {

// How the USD stage is composed before it is read (OpenSceneRequest
// variant_selections / time_code; see server/ingest/usd_ingest.h).
struct StageSelection {
  std::map<std::string, std::string> variant_selections;  // "<prim>:<set>" -> variant
  std::optional<double> time_code;                        // unset: the stage's start
  bool empty() const { return variant_selections.empty() && !time_code; }
};

// Opens one scene (the engine's open_scene in the daemon; a fake in tests).
// `cancelled` turns true once no caller waits for the open any more; the
// opener polls it (from the thread that called it) and throws
// pbgi::Cancelled.
using SceneOpener = std::function<std::shared_ptr<SceneSession>(
    const std::filesystem::path& path, const OpenOptions& options,
    const StageSelection& selection, const StageProgress& progress,
    const std::function<bool()>& cancelled)>;

// Bytes of a session outside the page cache.
using SessionMemory = std::function<uint64_t(const SceneSession&)>;
// Default: what the session is charged to the daemon's memory budget (its
// measured geometry and ray structure); a session opened without an
// accountant, ~200 bytes per triangle (soup + Embree BVH).
uint64_t estimate_session_memory(const SceneSession& session);

struct RegistryOptions {
  uint64_t scene_memory_budget = 0;   // bytes; 0 = never evict
  SessionMemory memory_of = estimate_session_memory;
};

// A ready session with its usage.
struct SceneUsage {
  std::shared_ptr<SceneSession> session;
  std::chrono::steady_clock::time_point last_used;
  uint64_t requests = 0;
  uint64_t memory_bytes = 0;
};

// An open in flight.
struct OpeningScene {
  std::string scene_path;
  std::string stage;
  float fraction = 0.f;
};

// Thread-safe.
class SceneRegistry {
 public:
  explicit SceneRegistry(SceneOpener opener, RegistryOptions options = {});
  ~SceneRegistry();

  // Returns the session of (canonical_path, options, selection), opening it
  // if no caller has yet. `progress` receives the stages of the open this
  // call runs or joins (possibly from other threads; calls are not
  // concurrent). `cancelled` says that this caller has left (it is polled
  // from other threads while this call runs: it must be thread-safe); the
  // call then throws pbgi::Cancelled, and the open goes on only if other
  // callers still wait for it. Errors of the open are rethrown to every
  // caller waiting for it and are not cached: a later call tries again. A
  // caller still there when an open it joined was cancelled (its other
  // callers left) starts it again.
  std::shared_ptr<SceneSession> open(const std::filesystem::path& canonical_path,
                                     const OpenOptions& options,
                                     const StageSelection& selection,
                                     const StageProgress& progress = {},
                                     const std::function<bool()>& cancelled = {});
  std::shared_ptr<SceneSession> open(const std::filesystem::path& canonical_path,
                                     const OpenOptions& options,
                                     const StageProgress& progress = {},
                                     const std::function<bool()>& cancelled = {});

  // The open session with this scene_id, or nullptr. Counts as a use (LRU).
  std::shared_ptr<SceneSession> find(const std::string& scene_id);

  // Forgets the session; false if no such scene_id is open. Requests that
  // hold it finish; its pages leave the cache when the last one does.
  bool unload(const std::string& scene_id);

  // Unloads idle sessions (held by no request), least recently used first,
  // until their memory (RegistryOptions::memory_of) reaches `bytes` or none
  // is left; returns true if it unloaded any. The memory accountant's
  // reclaimer: the sessions go (and release their charges) before it
  // returns, outside the registry's lock.
  bool unload_idle(uint64_t bytes);

  // All open sessions, ordered by scene path.
  std::vector<std::shared_ptr<SceneSession>> list() const;
  std::vector<SceneUsage> usage() const;
  std::vector<OpeningScene> opening() const;

  // Number of opens started, of sessions evicted by the memory budget.
  uint64_t opens_started() const;
  uint64_t evictions() const;  // both by the scene memory budget and unload_idle()
  uint64_t memory_budget() const { return options_.scene_memory_budget; }

 private:
  struct Pending;
  struct Entry {
    std::shared_ptr<SceneSession> session;
    std::string key;
    std::chrono::steady_clock::time_point last_used;
    uint64_t requests = 0;
    uint64_t memory_bytes = 0;
  };
  void evict_over_budget_locked(const std::string& keep_id);
  bool idle_locked(const Entry& entry) const;
  std::shared_ptr<SceneSession> open_once(const std::filesystem::path& canonical_path,
                                          const OpenOptions& options, const StageSelection& selection,
                                          const StageProgress& progress,
                                          const std::function<bool()>& cancelled, bool& joined);

  SceneOpener opener_;
  RegistryOptions options_;
  mutable std::shared_mutex mutex_;
  std::map<std::string, std::shared_ptr<Pending>> by_key_;   // includes opens in flight
  std::unordered_map<std::string, Entry> by_id_;              // ready only
  uint64_t opens_started_ = 0;
  uint64_t evictions_ = 0;
};

}  // namespace pbgi::service
