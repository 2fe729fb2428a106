// The Daemon in-process with a fake scene opener: private unix socket,
// TCP on port 0, preload, health, refusal of a second daemon on the same
// socket, and clean shutdown.
#include "server/daemon/daemon.h"

#include "client/lib/pbgi_client.h"
#include "common/errors.h"
#include "tests/server/service/fake_sessions.h"
#include "tests/server/service/temp_dir.h"
#include "tests/storage/pages/dead_process.h"

#include <grpcpp/generic/generic_stub.h>
#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>

#include <sys/stat.h>

#include <fstream>
#include <future>

namespace fs = std::filesystem;

namespace pbgi::daemon {
namespace {

class DaemonTest : public ::testing::Test {
 protected:
  void SetUp() override {
    fs::create_directories(tmp.path() / "scenes");
    std::ofstream(tmp.path() / "scenes" / "a.usda") << "#usda 1.0\n";
    options.scene_roots = {(tmp.path() / "scenes").string()};
    options.cache_dir = (tmp.path() / "cache").string();
    options.log_level = "warn";
  }
  service::SceneOpener opener() {
    return [this](const fs::path& path, const OpenOptions&, const service::StageSelection&,
                  const StageProgress&, const std::function<bool()>&) {
      ++opens;
      return testing::fake_session(path.string(), "id-" + path.stem().string());
    };
  }

  // grpc.health.v1.Health/Check for the whole server: SERVING is the
  // message {status: 1}, bytes 08 01.
  static std::string health_check(const std::string& address) {
    auto channel = grpc::CreateChannel(address, grpc::InsecureChannelCredentials());
    grpc::GenericStub stub(channel);
    grpc::ClientContext context;
    context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(10));
    grpc::Slice empty_message("", 0);  // HealthCheckRequest{service: ""}
    grpc::ByteBuffer request(&empty_message, 1), response;
    std::promise<grpc::Status> done;
    stub.UnaryCall(&context, "/grpc.health.v1.Health/Check", grpc::StubOptions(), &request,
                   &response, [&](grpc::Status s) { done.set_value(s); });
    const grpc::Status status = done.get_future().get();
    if (!status.ok()) return "error: " + status.error_message();
    std::vector<grpc::Slice> slices;
    response.Dump(&slices);
    std::string bytes;
    for (const auto& s : slices) bytes.append(reinterpret_cast<const char*>(s.begin()), s.size());
    return bytes;
  }

  testing::TempDir tmp;
  DaemonOptions options;
  int opens = 0;
};

TEST_F(DaemonTest, ServesOnAPrivateUnixSocketAndCleansUp) {
  const fs::path socket_path = tmp.path() / "cache" / "pbgid.sock";
  {
    Daemon daemon(options, opener());
    daemon.start();
    EXPECT_EQ(daemon.address(), "unix:" + socket_path.string());
    struct stat st {};
    ASSERT_EQ(::stat(socket_path.c_str(), &st), 0);
    EXPECT_TRUE(S_ISSOCK(st.st_mode));
    EXPECT_EQ(st.st_mode & 0777, 0600) << "only the owner may connect";

    client::PbgiClient client(daemon.address());
    const v1::SceneInfo info = client.open_scene("a.usda");
    EXPECT_EQ(info.scene_id(), "id-a");
    EXPECT_EQ(client.list_scenes().size(), 1u);
    EXPECT_EQ(health_check(daemon.address()), std::string("\x08\x01", 2));

    // A second daemon on the same socket is refused, the first keeps going.
    Daemon second(options, opener());
    EXPECT_THROW(second.start(), IoError);
    EXPECT_EQ(client.list_scenes().size(), 1u);

    daemon.shutdown(std::chrono::milliseconds(100));
    EXPECT_FALSE(fs::exists(socket_path)) << "the socket is removed on shutdown";
    daemon.shutdown(std::chrono::milliseconds(100));  // idempotent
  }
}

TEST_F(DaemonTest, ListensOnLoopbackTcpPortZero) {
  options.listen = "127.0.0.1:0";
  Daemon daemon(options, opener());
  daemon.start();
  ASSERT_EQ(daemon.address().rfind("127.0.0.1:", 0), 0u) << daemon.address();
  EXPECT_NE(daemon.address(), "127.0.0.1:0") << "the bound port is reported";
  client::PbgiClient client(daemon.address());
  EXPECT_TRUE(client.list_scenes().empty());
}

TEST_F(DaemonTest, PreloadsScenesBeforeReady) {
  options.preload = {"a.usda"};
  Daemon daemon(options, opener());
  daemon.start();
  EXPECT_EQ(opens, 1);
  client::PbgiClient client(daemon.address());
  ASSERT_EQ(client.list_scenes().size(), 1u);
  client.open_scene((tmp.path() / "scenes" / "a.usda").string());
  EXPECT_EQ(opens, 1) << "the preloaded session is reused";
}

TEST_F(DaemonTest, PreloadErrorsFailTheStart) {
  options.preload = {"missing.usda"};
  Daemon daemon(options, opener());
  EXPECT_THROW(daemon.start(), NotFound);
}

TEST_F(DaemonTest, TheCacheDirectoryIsPrivateAndLeftoversOfCrashedRunsGoAtStart) {
  const pid_t dead = testing::dead_process_id();
  const fs::path cache = options.cache_dir;
  fs::create_directories(cache);
  const fs::path staging = cache / ("0123abcd.tmp-" + std::to_string(dead) + "-0123456789abcdef");
  const fs::path corrupt = cache / "4567cdef.corrupt-1700000000";
  const fs::path live = cache / "89abcdef.tmp-1-0123456789abcdef";  // pid 1 runs
  for (const fs::path& dir : {staging, corrupt, live}) {
    fs::create_directories(dir);
    std::ofstream(dir / "pages.pbgp") << "x";
  }
  Daemon daemon(options, opener());
  daemon.start();
  EXPECT_FALSE(fs::exists(staging)) << "staging directory of a dead build";
  EXPECT_FALSE(fs::exists(corrupt)) << "corrupt page set moved aside by an earlier run";
  EXPECT_TRUE(fs::exists(live)) << "a running process' staging directory";

  // A cache directory the daemon creates is 0700 whatever the umask.
  const fs::path fresh = tmp.path() / "fresh" / "cache";
  options.cache_dir = fresh.string();
  options.listen = "unix:" + (tmp.path() / "fresh.sock").string();
  const mode_t previous = ::umask(022);
  Daemon second(options, opener());
  second.start();
  ::umask(previous);
  EXPECT_EQ(fs::status(fresh).permissions(), fs::perms::owner_all);
}

TEST_F(DaemonTest, InvalidOptionsFailTheStart) {
  options.scene_roots = {(tmp.path() / "no-such-root").string()};
  Daemon daemon(options, opener());
  EXPECT_THROW(daemon.start(), IoError);
}

}  // namespace
}  // namespace pbgi::daemon
