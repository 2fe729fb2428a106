// pbgid's transport security in-process (fake scene opener): TLS on
// loopback TCP with certificates made by make_test_certs.sh for this run,
// mutual TLS, bearer tokens (missing / wrong / right), the refusal of
// plaintext TCP off loopback, and a token file others can read.
#include "server/daemon/daemon.h"

#include "client/lib/pbgi_client.h"
#include "client/stress/health_check.h"
#include "common/errors.h"
#include "tests/server/service/fake_sessions.h"
#include "tests/server/service/temp_dir.h"

#include <grpcpp/generic/generic_stub.h>
#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>

#include <sys/stat.h>

#include <cstdlib>
#include <fstream>

namespace fs = std::filesystem;

namespace pbgi::daemon {
namespace {

using client::ClientOptions;
using client::PbgiClient;
using client::RpcError;

constexpr const char* kToken = "s3cret-token-for-tests";

class DaemonSecurityTest : public ::testing::Test {
 protected:
  void SetUp() override {
    fs::create_directories(tmp.path() / "scenes");
    std::ofstream(tmp.path() / "scenes" / "a.usda") << "#usda 1.0\n";
    pki = tmp.path() / "pki";
    const std::string script =
        std::string(PBGI_TEST_SOURCE_DIR) + "/tests/server/daemon/make_test_certs.sh";
    ASSERT_EQ(std::system(("sh '" + script + "' '" + pki.string() + "'").c_str()), 0)
        << "openssl could not make the test certificates";
    token_file = tmp.path() / "token";
    std::ofstream(token_file) << kToken << "\n";
    fs::permissions(token_file, fs::perms::owner_read | fs::perms::owner_write);

    options.scene_roots = {(tmp.path() / "scenes").string()};
    options.cache_dir = (tmp.path() / "cache").string();
    options.log_level = "error";
    options.listen = "127.0.0.1:0";
    options.tls_cert = (pki / "server.crt").string();
    options.tls_key = (pki / "server.key").string();
    options.auth_token_file = token_file.string();
  }
  service::SceneOpener opener() {
    return [](const fs::path& path, const OpenOptions&, const service::StageSelection&,
              const StageProgress&, const std::function<bool()>&) {
      return testing::fake_session(path.string(), "id-" + path.stem().string());
    };
  }
  // A client that gives up quickly (no retries) for refused connections.
  ClientOptions client_options(const std::string& token, const std::string& ca = "ca.crt") {
    ClientOptions o;
    o.max_attempts = 1;
    o.call_deadline = std::chrono::seconds(5);
    o.token = token;
    if (!ca.empty()) o.tls_ca_file = (pki / ca).string();
    return o;
  }
  static grpc::StatusCode code_of(const std::function<void()>& call, std::string* message = nullptr) {
    try {
      call();
    } catch (const RpcError& e) {
      if (message) *message = e.what();
      return e.code();
    }
    return grpc::StatusCode::OK;
  }

  testing::TempDir tmp;
  fs::path pki, token_file;
  DaemonOptions options;
};

TEST_F(DaemonSecurityTest, TlsWithBearerTokenEndToEnd) {
  Daemon daemon(options, opener());
  daemon.start();
  ASSERT_EQ(daemon.address().rfind("127.0.0.1:", 0), 0u) << daemon.address();

  // No token, a wrong one, a malformed header: UNAUTHENTICATED, and the
  // message never reveals the expected token.
  std::string message;
  EXPECT_EQ(code_of([&] { PbgiClient(daemon.address(), client_options("")).list_scenes(); },
                    &message),
            grpc::StatusCode::UNAUTHENTICATED);
  EXPECT_NE(message.find("bearer token"), std::string::npos) << message;
  EXPECT_EQ(code_of([&] {
              PbgiClient(daemon.address(), client_options("wrong")).open_scene("a.usda");
            }, &message),
            grpc::StatusCode::UNAUTHENTICATED);
  EXPECT_EQ(message.find(kToken), std::string::npos) << message;
  EXPECT_EQ(code_of([&] {
              PbgiClient(daemon.address(), client_options(std::string(kToken) + "x"))
                  .list_scenes();
            }),
            grpc::StatusCode::UNAUTHENTICATED)
      << "a token with the right prefix is still wrong";

  // The right token over TLS works for every call.
  PbgiClient client(daemon.address(), client_options(kToken));
  const v1::SceneInfo info = client.open_scene("a.usda");
  EXPECT_EQ(info.scene_id(), "id-a");
  EXPECT_EQ(client.list_scenes().size(), 1u);
  EXPECT_EQ(client.status().scenes_size(), 1);

  // Plaintext to the TLS port, or TLS trusting another CA: no connection.
  EXPECT_EQ(code_of([&] {
              PbgiClient(daemon.address(), client_options(kToken, "")).list_scenes();
            }),
            grpc::StatusCode::UNAVAILABLE);
  EXPECT_EQ(code_of([&] {
              PbgiClient(daemon.address(), client_options(kToken, "other-ca.crt")).list_scenes();
            }),
            grpc::StatusCode::UNAVAILABLE);

  // The standard health service answers without a token (probes have none).
  grpc::SslCredentialsOptions ssl;
  std::ifstream ca(pki / "ca.crt");
  ssl.pem_root_certs.assign(std::istreambuf_iterator<char>(ca), {});
  auto channel = grpc::CreateChannel(daemon.address(), grpc::SslCredentials(ssl));
  grpc::ClientContext context;
  context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(5));
  EXPECT_TRUE(channel->WaitForConnected(context.deadline()));
  // And after all the refusals, the right client still works.
  EXPECT_EQ(client.list_scenes().size(), 1u);
}

TEST_F(DaemonSecurityTest, HealthCheckOverTlsWithAToken) {
  Daemon daemon(options, opener());
  daemon.start();
  // What `pbgi health --tls-ca ca.crt --token ...` runs (the container's
  // HEALTHCHECK and the Kubernetes probes).
  const stress::HealthReply reply =
      stress::check_health(daemon.address(), "pbgi.v1.Pbgi", std::chrono::seconds(5), client_options(kToken));
  EXPECT_EQ(reply.status, stress::HealthStatus::Serving) << reply.detail;
  EXPECT_EQ(stress::check_health(daemon.address(), "", std::chrono::seconds(5), client_options("")).status,
            stress::HealthStatus::Serving)
      << "the health service needs no token";
  EXPECT_EQ(stress::check_health(daemon.address(), "", std::chrono::seconds(2)).status,
            stress::HealthStatus::Unreachable)
      << "plaintext cannot reach a TLS daemon";
}

// A ServerReflectionInfo call listing the services: its status.
grpc::Status list_services_by_reflection(const std::string& address, const ClientOptions& connection) {
  grpc::GenericStub stub(client::make_channel(address, connection));
  grpc::ClientContext context;
  context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(5));
  grpc::CompletionQueue cq;
  void* tag = nullptr;
  bool ok = false;
  auto call = stub.PrepareCall(&context, "/grpc.reflection.v1alpha.ServerReflection/ServerReflectionInfo", &cq);
  call->StartCall(reinterpret_cast<void*>(1));
  cq.Next(&tag, &ok);
  // ServerReflectionRequest { string list_services = 7; } = "*".
  const std::string request = std::string("\x3a\x01*", 3);
  grpc::Slice slice(request);
  call->Write(grpc::ByteBuffer(&slice, 1), reinterpret_cast<void*>(2));
  cq.Next(&tag, &ok);
  call->WritesDone(reinterpret_cast<void*>(3));
  cq.Next(&tag, &ok);
  grpc::ByteBuffer response;
  call->Read(&response, reinterpret_cast<void*>(4));
  cq.Next(&tag, &ok);
  grpc::Status status;
  call->Finish(&status, reinterpret_cast<void*>(5));
  cq.Next(&tag, &ok);
  cq.Shutdown();
  while (cq.Next(&tag, &ok)) {
  }
  return status;
}

TEST_F(DaemonSecurityTest, ReflectionIsServedOnlyWithoutAToken) {
  {
    Daemon daemon(options, opener());
    daemon.start();
    EXPECT_EQ(list_services_by_reflection(daemon.address(), client_options(kToken)).error_code(),
              grpc::StatusCode::UNIMPLEMENTED)
        << "reflection would be the one service open without the token";
  }
  options.auth_token_file = "";
  Daemon open_daemon(options, opener());
  open_daemon.start();
  const grpc::Status status = list_services_by_reflection(open_daemon.address(), client_options(""));
  EXPECT_TRUE(status.ok()) << status.error_message();
}

// The real opener (USD reader process): a scene inside the root whose
// sublayer lies outside is PERMISSION_DENIED, and the answer does not say
// where the sublayer is.
TEST_F(DaemonSecurityTest, AScenePullingInALayerOutsideTheRootsIsPermissionDenied) {
  fs::create_directories(tmp.path() / "private");
  std::ofstream(tmp.path() / "private" / "secret.usda")
      << "#usda 1.0\ndef Mesh \"Secret\"\n{\n    int[] faceVertexCounts = [3]\n"
         "    int[] faceVertexIndices = [0, 1, 2]\n    point3f[] points = [(0,0,0), (1,0,0), (0,1,0)]\n}\n";
  std::ofstream(tmp.path() / "scenes" / "escape.usda")
      << "#usda 1.0\n(\n    subLayers = [@" << (tmp.path() / "private" / "secret.usda").string() << "@]\n)\n";
  options.listen = "";
  options.tls_cert = options.tls_key = "";
  options.auth_token_file = "";
  Daemon daemon(options);  // the engine's opener
  daemon.start();
  std::string message;
  EXPECT_EQ(code_of([&] { PbgiClient(daemon.address(), client_options("", "")).open_scene("escape.usda"); },
                    &message),
            grpc::StatusCode::PERMISSION_DENIED)
      << message;
  EXPECT_NE(message.find("outside the scene roots"), std::string::npos) << message;
  EXPECT_EQ(message.find("private"), std::string::npos) << "discloses the outside path: " << message;
}

TEST_F(DaemonSecurityTest, MutualTlsRequiresAClientCertificateFromTheCa) {
  options.tls_client_ca = (pki / "ca.crt").string();
  Daemon daemon(options, opener());
  daemon.start();

  EXPECT_EQ(code_of([&] { PbgiClient(daemon.address(), client_options(kToken)).list_scenes(); }),
            grpc::StatusCode::UNAVAILABLE)
      << "no client certificate: the handshake fails";

  ClientOptions with_cert = client_options(kToken);
  with_cert.tls_cert_file = (pki / "client.crt").string();
  with_cert.tls_key_file = (pki / "client.key").string();
  EXPECT_TRUE(PbgiClient(daemon.address(), with_cert).list_scenes().empty());

  // A certificate is not a token: both are required.
  with_cert.token = "";
  EXPECT_EQ(code_of([&] { PbgiClient(daemon.address(), with_cert).list_scenes(); }),
            grpc::StatusCode::UNAUTHENTICATED);
}

TEST_F(DaemonSecurityTest, TokenAlsoGuardsTheUnixSocket) {
  options.listen = "";
  options.tls_cert = options.tls_key = "";
  options.auth_token_file = "";
  options.auth_token = kToken;  // as PBGI_AUTH_TOKEN gives it
  Daemon daemon(options, opener());
  daemon.start();
  ClientOptions plain;
  plain.max_attempts = 1;
  EXPECT_EQ(code_of([&] { PbgiClient(daemon.address(), plain).list_scenes(); }),
            grpc::StatusCode::UNAUTHENTICATED);
  plain.token = kToken;
  EXPECT_TRUE(PbgiClient(daemon.address(), plain).list_scenes().empty());
}

TEST_F(DaemonSecurityTest, PlaintextTcpOffLoopbackIsRefusedUnlessTlsOrAllowed) {
  options.listen = "0.0.0.0:0";
  EXPECT_NO_THROW(options.validate()) << "TLS makes a remote listener acceptable";
  options.tls_cert = options.tls_key = "";
  try {
    options.validate();
    FAIL() << "plaintext on 0.0.0.0 accepted";
  } catch (const InvalidArgument& e) {
    EXPECT_NE(std::string(e.what()).find("0.0.0.0:0"), std::string::npos) << e.what();
  }
  options.allow_insecure_remote = true;
  EXPECT_NO_THROW(options.validate());

  // Half a TLS configuration is an error, not silently plaintext.
  options.tls_cert = (pki / "server.crt").string();
  EXPECT_THROW(options.validate(), InvalidArgument);
  options.tls_key = (pki / "server.key").string();
  options.tls_cert = "";
  options.tls_client_ca = (pki / "ca.crt").string();
  EXPECT_THROW(options.validate(), InvalidArgument);
}

TEST_F(DaemonSecurityTest, BadCredentialsFilesFailTheStart) {
  fs::permissions(token_file, fs::perms::group_read | fs::perms::others_read,
                  fs::perm_options::add);
  {
    Daemon daemon(options, opener());
    EXPECT_THROW(daemon.start(), InvalidArgument) << "a token file others can read";
  }
  fs::permissions(token_file, fs::perms::owner_read | fs::perms::owner_write);
  options.tls_key = (pki / "missing.key").string();
  Daemon daemon(options, opener());
  EXPECT_THROW(daemon.start(), IoError);
}

TEST_F(DaemonSecurityTest, ATlsKeyOthersCanReadFailsTheStart) {
  fs::permissions(pki / "server.key", fs::perms::group_read | fs::perms::others_read, fs::perm_options::add);
  Daemon daemon(options, opener());
  try {
    daemon.start();
    FAIL() << "a world-readable TLS key was accepted";
  } catch (const InvalidArgument& e) {
    EXPECT_NE(std::string(e.what()).find("tls_key"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("644"), std::string::npos) << e.what();
  }
}

TEST_F(DaemonSecurityTest, AKeyOfAnotherCertificateIsReportedAsSuch) {
  options.tls_key = (pki / "client.key").string();  // a valid key, not the server certificate's
  Daemon daemon(options, opener());
  try {
    daemon.start();
    FAIL() << "a mismatched TLS key was accepted";
  } catch (const InvalidArgument& e) {
    const std::string message = e.what();
    EXPECT_NE(message.find("does not match"), std::string::npos) << message;
    EXPECT_NE(message.find("client.key"), std::string::npos) << message;
    EXPECT_EQ(message.find("address in use"), std::string::npos) << message;
  }
}

}  // namespace
}  // namespace pbgi::daemon
