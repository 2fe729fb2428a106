#include "server/service/scene_registry.h"

#include "common/errors.h"
#include "server/service/options_codec.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <malloc.h>

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <exception>
#include <mutex>
#include <tuple>
#include <vector>

namespace pbgi::service {
namespace {

using Clock = std::chrono::steady_clock;

std::string selection_key(const StageSelection& s) {
  std::string key;
  for (const auto& [where, variant] : s.variant_selections) key += where + '=' + variant + ';';
  if (s.time_code) key += fmt::format("t={}", *s.time_code);
  return key;
}

}  // namespace

uint64_t estimate_session_memory(const SceneSession& session) {
  if (session.memory.bytes() > 0) return session.memory.bytes();
  // Per triangle: the soup (positions, normals, uvs: ~100 bytes) and
  // Embree's BVH (~100 bytes). Good to a factor of two, which is what an
  // eviction policy needs.
  constexpr uint64_t kBytesPerTriangle = 200;
  return session.info.triangle_count * kBytesPerTriangle;
}

// One open, shared by its first caller (who runs it) and any waiters.
struct SceneRegistry::Pending {
  std::string scene_path;
  std::mutex mutex;
  std::condition_variable changed;
  std::string stage;
  float fraction = 0.f;
  uint64_t progress_seq = 0;   // bumped on each progress report
  bool done = false;
  std::shared_ptr<SceneSession> session;
  std::exception_ptr error;
  // The callers still in open() for it, each by its `cancelled` (empty: one
  // that never leaves). The open is abandoned once every one has left.
  std::vector<const std::function<bool()>*> callers;

  bool abandoned() {
    std::lock_guard lock(mutex);
    for (const std::function<bool()>* c : callers) {
      if (!*c || !(*c)()) return false;
    }
    return true;
  }
};

namespace {

// A caller's place in Pending::callers for as long as it is in open().
class CallerSeat {
 public:
  CallerSeat(std::mutex& mutex, std::vector<const std::function<bool()>*>& callers,
             const std::function<bool()>& cancelled)
      : mutex_(mutex), callers_(callers), cancelled_(&cancelled) {
    std::lock_guard lock(mutex_);
    callers_.push_back(cancelled_);
  }
  ~CallerSeat() {
    std::lock_guard lock(mutex_);
    callers_.erase(std::find(callers_.begin(), callers_.end(), cancelled_));
  }
  CallerSeat(const CallerSeat&) = delete;
  CallerSeat& operator=(const CallerSeat&) = delete;

 private:
  std::mutex& mutex_;
  std::vector<const std::function<bool()>*>& callers_;
  const std::function<bool()>* cancelled_;
};

}  // namespace

SceneRegistry::SceneRegistry(SceneOpener opener, RegistryOptions options)
    : opener_(std::move(opener)), options_(std::move(options)) {
  if (!options_.memory_of) options_.memory_of = estimate_session_memory;
}
SceneRegistry::~SceneRegistry() = default;

std::shared_ptr<SceneSession> SceneRegistry::open(const std::filesystem::path& canonical_path,
                                                  const OpenOptions& options,
                                                  const StageProgress& progress,
                                                  const std::function<bool()>& cancelled) {
  return open(canonical_path, options, StageSelection{}, progress, cancelled);
}

std::shared_ptr<SceneSession> SceneRegistry::open(const std::filesystem::path& canonical_path,
                                                  const OpenOptions& options,
                                                  const StageSelection& selection,
                                                  const StageProgress& progress,
                                                  const std::function<bool()>& cancelled) {
  for (;;) {
    bool joined = false;
    try {
      return open_once(canonical_path, options, selection, progress, cancelled, joined);
    } catch (const Cancelled&) {
      // An open this caller joined was cancelled because its other callers
      // left while this one stayed: it was forgotten, so the next attempt
      // starts it again.
      if (!joined || (cancelled && cancelled())) throw;
      spdlog::info("the open of '{}' this request joined was cancelled by its other callers; opening again",
                   canonical_path.string());
    }
  }
}

std::shared_ptr<SceneSession> SceneRegistry::open_once(const std::filesystem::path& canonical_path,
                                                       const OpenOptions& options,
                                                       const StageSelection& selection,
                                                       const StageProgress& progress,
                                                       const std::function<bool()>& cancelled,
                                                       bool& joined) {
  const std::string key = canonical_path.string() + '\n' + open_options_key(options) + '\n' +
                          selection_key(selection);

  // 1. Known key: join it, unless it names a session unloaded since
  //    (then it is forgotten and opened again).
  std::shared_ptr<Pending> pending;
  bool runs_open = false;
  {
    std::unique_lock lock(mutex_);
    auto it = by_key_.find(key);
    if (it != by_key_.end()) {
      bool stale = false;
      {
        std::lock_guard pending_lock(it->second->mutex);
        stale = it->second->done && it->second->session &&
                !by_id_.count(it->second->session->info.scene_id);
      }
      if (stale) {
        by_key_.erase(it);
      } else {
        pending = it->second;
      }
    }
    // 2. Not known: register an open in flight.
    if (!pending) {
      pending = std::make_shared<Pending>();
      pending->scene_path = canonical_path.string();
      by_key_.emplace(key, pending);
      ++opens_started_;
      runs_open = true;
    }
  }
  joined = !runs_open;

  // 3a. First caller: run the open outside the registry lock, publishing
  //     progress to the waiters.
  if (runs_open) {
    const CallerSeat seat(pending->mutex, pending->callers, cancelled);
    std::mutex progress_mutex;  // the engine may report from worker threads
    auto report = [&](const std::string& stage, float fraction) {
      {
        std::lock_guard lock(pending->mutex);
        pending->stage = stage;
        pending->fraction = fraction;
        ++pending->progress_seq;
      }
      pending->changed.notify_all();
      if (progress) {
        std::lock_guard lock(progress_mutex);
        progress(stage, fraction);
      }
    };
    std::shared_ptr<SceneSession> session;
    std::exception_ptr error;
    try {
      session = opener_(canonical_path, options, selection, report, [&] { return pending->abandoned(); });
      if (!session) throw Error(fmt::format("opening '{}' returned no session", canonical_path.string()));
    } catch (...) {
      error = std::current_exception();
    }
    {
      std::unique_lock lock(mutex_);
      if (error) {
        by_key_.erase(key);  // not cached: the next request tries again
      } else {
        Entry entry{session, key, Clock::now(), 0, options_.memory_of(*session)};
        auto [it, inserted] = by_id_.try_emplace(session->info.scene_id, std::move(entry));
        if (!inserted) {
          // The same page set under another key (e.g. a path through a
          // different root): serve the session already registered.
          session = it->second.session;
        }
        evict_over_budget_locked(session->info.scene_id);
      }
    }
    {
      std::lock_guard lock(pending->mutex);
      pending->done = true;
      pending->session = session;
      pending->error = error;
    }
    pending->changed.notify_all();
    if (error) std::rethrow_exception(error);
    return session;
  }

  // 3b. Someone else opens it: relay their progress until done. The wait
  //     wakes up periodically only to notice a cancelled caller; while
  //     seated, this caller keeps the open from being abandoned.
  const CallerSeat seat(pending->mutex, pending->callers, cancelled);
  std::unique_lock lock(pending->mutex);
  uint64_t seen = 0;
  while (!pending->done) {
    pending->changed.wait_for(lock, std::chrono::milliseconds(100),
                              [&] { return pending->done || pending->progress_seq != seen; });
    if (!pending->done && pending->progress_seq != seen) {
      seen = pending->progress_seq;
      std::string stage = pending->stage;
      float fraction = pending->fraction;
      lock.unlock();
      if (progress) progress(stage, fraction);
      lock.lock();
    }
    if (!pending->done && cancelled && cancelled()) {
      throw Cancelled(fmt::format("cancelled while waiting for '{}' to open",
                                  canonical_path.string()));
    }
  }
  if (pending->error) std::rethrow_exception(pending->error);
  std::shared_ptr<SceneSession> session = pending->session;
  lock.unlock();
  // Joining an open counts as a use; a session unloaded meanwhile is
  // still returned (it stays valid while held).
  find(session->info.scene_id);
  return session;
}

void SceneRegistry::evict_over_budget_locked(const std::string& keep_id) {
  if (options_.scene_memory_budget == 0) return;
  for (;;) {
    uint64_t total = 0;
    for (const auto& [id, entry] : by_id_) total += entry.memory_bytes;
    if (total <= options_.scene_memory_budget) return;
    auto victim = by_id_.end();
    for (auto it = by_id_.begin(); it != by_id_.end(); ++it) {
      if (it->first == keep_id) continue;
      if (victim == by_id_.end() || it->second.last_used < victim->second.last_used) victim = it;
    }
    if (victim == by_id_.end()) return;  // only the new scene left: it stays
    spdlog::info("unloading scene {} ('{}', ~{} MB) to stay within the scene memory budget",
                 victim->first, victim->second.session->info.scene_path,
                 victim->second.memory_bytes >> 20);
    by_key_.erase(victim->second.key);
    by_id_.erase(victim);
    ++evictions_;
  }
}

bool SceneRegistry::idle_locked(const Entry& entry) const {
  // The registry's own references: the entry, and the finished open's
  // record (by_key_) that callers joining it read the session from.
  long own = 1;
  if (auto it = by_key_.find(entry.key); it != by_key_.end()) {
    std::lock_guard pending_lock(it->second->mutex);
    if (it->second->session == entry.session) ++own;
  }
  return entry.session.use_count() <= own;
}

bool SceneRegistry::unload_idle(uint64_t bytes) {
  // Freed outside the lock: a session's destruction releases its Embree
  // scene, its readers' cached pages and its memory charge.
  std::vector<std::shared_ptr<SceneSession>> unloaded;
  {
    std::unique_lock lock(mutex_);
    uint64_t freed = 0;
    while (freed < bytes) {
      auto victim = by_id_.end();
      for (auto it = by_id_.begin(); it != by_id_.end(); ++it) {
        if (!idle_locked(it->second)) continue;
        if (victim == by_id_.end() || it->second.last_used < victim->second.last_used) victim = it;
      }
      if (victim == by_id_.end()) break;
      spdlog::info("unloading idle scene {} ('{}', {} MiB) to make room within the memory budget", victim->first,
                   victim->second.session->info.scene_path, victim->second.memory_bytes >> 20);
      freed += victim->second.memory_bytes;
      unloaded.push_back(std::move(victim->second.session));
      by_key_.erase(victim->second.key);
      by_id_.erase(victim);
      ++evictions_;
    }
  }
  const bool any = !unloaded.empty();
  unloaded.clear();
  // The heap they freed goes back to the system: glibc keeps freed chunks
  // in its arenas (the worker threads' too), where the next scene may not
  // fit them, and the budget would pay for them twice. (pbgid itself links
  // jemalloc, which returns them on its own; this is for builds without
  // it, e.g. under sanitizers.)
  if (any) ::malloc_trim(0);
  return any;
}

std::shared_ptr<SceneSession> SceneRegistry::find(const std::string& scene_id) {
  std::unique_lock lock(mutex_);
  auto it = by_id_.find(scene_id);
  if (it == by_id_.end()) return nullptr;
  it->second.last_used = Clock::now();
  ++it->second.requests;
  return it->second.session;
}

bool SceneRegistry::unload(const std::string& scene_id) {
  std::unique_lock lock(mutex_);
  auto it = by_id_.find(scene_id);
  if (it == by_id_.end()) return false;
  by_key_.erase(it->second.key);
  by_id_.erase(it);
  return true;
}

std::vector<SceneUsage> SceneRegistry::usage() const {
  std::vector<SceneUsage> out;
  {
    std::shared_lock lock(mutex_);
    out.reserve(by_id_.size());
    for (const auto& [id, e] : by_id_) {
      out.push_back({e.session, e.last_used, e.requests, e.memory_bytes});
    }
  }
  std::sort(out.begin(), out.end(), [](const SceneUsage& a, const SceneUsage& b) {
    return std::tie(a.session->info.scene_path, a.session->info.scene_id) <
           std::tie(b.session->info.scene_path, b.session->info.scene_id);
  });
  return out;
}

std::vector<std::shared_ptr<SceneSession>> SceneRegistry::list() const {
  std::vector<std::shared_ptr<SceneSession>> out;
  for (SceneUsage& u : usage()) out.push_back(std::move(u.session));
  return out;
}

std::vector<OpeningScene> SceneRegistry::opening() const {
  std::vector<std::shared_ptr<Pending>> pendings;
  {
    std::shared_lock lock(mutex_);
    for (const auto& [key, p] : by_key_) pendings.push_back(p);
  }
  std::vector<OpeningScene> out;
  for (const auto& p : pendings) {
    std::lock_guard lock(p->mutex);
    if (!p->done) out.push_back({p->scene_path, p->stage, p->fraction});
  }
  return out;
}

uint64_t SceneRegistry::opens_started() const {
  std::shared_lock lock(mutex_);
  return opens_started_;
}

uint64_t SceneRegistry::evictions() const {
  std::shared_lock lock(mutex_);
  return evictions_;
}

}  // namespace pbgi::service
