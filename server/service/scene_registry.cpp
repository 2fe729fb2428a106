#include "server/service/scene_registry.h"

#include "server/service/options_codec.h"
#include "storage/format/errors.h"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <exception>
#include <mutex>
#include <tuple>

namespace pbgi::service {

// One open, shared by its first caller (who runs it) and any waiters.
struct SceneRegistry::Pending {
  std::mutex mutex;
  std::condition_variable changed;
  std::string stage;
  float fraction = 0.f;
  uint64_t progress_seq = 0;   // bumped on each progress report
  bool done = false;
  std::shared_ptr<SceneSession> session;
  std::exception_ptr error;
};

SceneRegistry::SceneRegistry(SceneOpener opener) : opener_(std::move(opener)) {}
SceneRegistry::~SceneRegistry() = default;

std::shared_ptr<SceneSession> SceneRegistry::open(const std::filesystem::path& canonical_path,
                                                  const OpenOptions& options,
                                                  const StageProgress& progress,
                                                  const std::function<bool()>& cancelled) {
  const std::string key = canonical_path.string() + '\n' + open_options_key(options);

  // 1. Fast path: already open (shared lock only).
  std::shared_ptr<Pending> pending;
  {
    std::shared_lock lock(mutex_);
    auto it = by_key_.find(key);
    if (it != by_key_.end()) pending = it->second;
  }

  // 2. Not known: register an open in flight, unless another caller did
  //    between the two locks.
  bool runs_open = false;
  if (!pending) {
    std::unique_lock lock(mutex_);
    auto [it, inserted] = by_key_.try_emplace(key);
    if (inserted) {
      it->second = std::make_shared<Pending>();
      ++opens_started_;
      runs_open = true;
    }
    pending = it->second;
  }

  // 3a. First caller: run the open outside the registry lock, publishing
  //     progress to the waiters.
  if (runs_open) {
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
      session = opener_(canonical_path, options, report);
      if (!session) throw Error(fmt::format("opening '{}' returned no session", canonical_path.string()));
    } catch (...) {
      error = std::current_exception();
    }
    {
      std::unique_lock lock(mutex_);
      if (error) {
        by_key_.erase(key);  // not cached: the next request tries again
      } else {
        by_id_.try_emplace(session->info.scene_id, session);
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
  //     wakes up periodically only to notice a cancelled caller.
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
  return pending->session;
}

std::shared_ptr<SceneSession> SceneRegistry::find(const std::string& scene_id) const {
  std::shared_lock lock(mutex_);
  auto it = by_id_.find(scene_id);
  return it == by_id_.end() ? nullptr : it->second;
}

std::vector<std::shared_ptr<SceneSession>> SceneRegistry::list() const {
  std::vector<std::shared_ptr<SceneSession>> out;
  {
    std::shared_lock lock(mutex_);
    out.reserve(by_id_.size());
    for (const auto& [id, session] : by_id_) out.push_back(session);
  }
  std::sort(out.begin(), out.end(), [](const auto& a, const auto& b) {
    return std::tie(a->info.scene_path, a->info.scene_id) <
           std::tie(b->info.scene_path, b->info.scene_id);
  });
  return out;
}

uint64_t SceneRegistry::opens_started() const {
  std::shared_lock lock(mutex_);
  return opens_started_;
}

}  // namespace pbgi::service
