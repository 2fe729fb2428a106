#include "client/stress/health_check.h"

#include "client/lib/pbgi_client.h"
#include "common/errors.h"

#include <fmt/format.h>
#include <grpcpp/generic/generic_stub.h>
#include <grpcpp/grpcpp.h>

namespace pbgi::stress {
namespace {

constexpr const char* kCheckMethod = "/grpc.health.v1.Health/Check";

void put_varint(uint64_t v, std::string& out) {
  while (v >= 0x80) {
    out.push_back(static_cast<char>((v & 0x7f) | 0x80));
    v >>= 7;
  }
  out.push_back(static_cast<char>(v));
}

// Reads a varint at `pos`; throws on truncation or more than 10 bytes.
uint64_t get_varint(const std::string& in, size_t& pos) {
  uint64_t v = 0;
  for (int shift = 0; shift < 70; shift += 7) {
    if (pos >= in.size()) throw InvalidArgument("health response: truncated varint");
    const auto byte = static_cast<uint8_t>(in[pos++]);
    v |= uint64_t(byte & 0x7f) << shift;
    if (!(byte & 0x80)) return v;
  }
  throw InvalidArgument("health response: varint longer than 10 bytes");
}

}  // namespace

std::string encode_health_request(const std::string& service) {
  std::string out;
  if (service.empty()) return out;  // proto3: the default value is not sent
  out.push_back(0x0a);              // field 1, length-delimited
  put_varint(service.size(), out);
  return out + service;
}

HealthStatus decode_health_response(const std::string& bytes) {
  uint64_t status = 0;  // absent field = UNKNOWN
  size_t pos = 0;
  while (pos < bytes.size()) {
    const uint64_t tag = get_varint(bytes, pos);
    const uint64_t field = tag >> 3, wire = tag & 7;
    if (field == 0) throw InvalidArgument("health response: field number 0");
    if (wire == 0) {
      const uint64_t v = get_varint(bytes, pos);
      if (field == 1) status = v;
    } else if (wire == 2) {
      const uint64_t n = get_varint(bytes, pos);
      if (n > bytes.size() - pos) throw InvalidArgument("health response: truncated field");
      pos += n;
    } else if (wire == 1 || wire == 5) {
      const size_t n = wire == 1 ? 8 : 4;
      if (n > bytes.size() - pos) throw InvalidArgument("health response: truncated field");
      pos += n;
    } else {
      throw InvalidArgument(fmt::format("health response: wire type {} unexpected", wire));
    }
  }
  if (status > 3) return HealthStatus::Unknown;  // a newer enum value
  return static_cast<HealthStatus>(status);
}

HealthReply check_health(const std::string& address, const std::string& service,
                         std::chrono::milliseconds timeout, const client::ClientOptions& connection) {
  HealthReply reply;
  std::shared_ptr<grpc::Channel> channel;
  try {
    channel = client::make_channel(client::normalize_address(address), connection);
  } catch (const Error& e) {
    reply.detail = e.what();
    return reply;
  }
  grpc::GenericStub stub(channel);
  grpc::ClientContext context;
  context.set_deadline(std::chrono::system_clock::now() + timeout);
  context.set_wait_for_ready(false);
  if (!connection.token.empty()) context.AddMetadata("authorization", "Bearer " + connection.token);

  const std::string request = encode_health_request(service);
  grpc::Slice slice(request);
  grpc::ByteBuffer request_buffer(&slice, 1);
  grpc::ByteBuffer response_buffer;
  grpc::Status status;
  grpc::CompletionQueue cq;
  auto call = stub.PrepareUnaryCall(&context, kCheckMethod, request_buffer, &cq);
  call->StartCall();
  call->Finish(&response_buffer, &status, reinterpret_cast<void*>(1));
  void* tag = nullptr;
  bool ok = false;
  const bool got = cq.Next(&tag, &ok);
  const bool call_ok = ok;
  cq.Shutdown();
  while (cq.Next(&tag, &ok)) {
  }  // a completion queue is drained before it is destroyed
  if (!got || !call_ok) {
    reply.detail = "completion queue failed";
    return reply;
  }
  if (!status.ok()) {
    if (status.error_code() == grpc::StatusCode::NOT_FOUND) {
      reply.status = HealthStatus::ServiceUnknown;  // the health service's answer
    }
    reply.detail = fmt::format("{}: {}", client::status_code_name(status.error_code()),
                               status.error_message());
    return reply;
  }
  std::vector<grpc::Slice> slices;
  response_buffer.Dump(&slices);
  std::string bytes;
  for (const grpc::Slice& s : slices) bytes.append(reinterpret_cast<const char*>(s.begin()), s.size());
  try {
    reply.status = decode_health_response(bytes);
  } catch (const Error& e) {
    reply.detail = e.what();
  }
  return reply;
}

const char* health_status_name(HealthStatus status) {
  switch (status) {
    case HealthStatus::Unknown: return "UNKNOWN";
    case HealthStatus::Serving: return "SERVING";
    case HealthStatus::NotServing: return "NOT_SERVING";
    case HealthStatus::ServiceUnknown: return "SERVICE_UNKNOWN";
    case HealthStatus::Unreachable: return "UNREACHABLE";
  }
  return "?";
}

}  // namespace pbgi::stress
