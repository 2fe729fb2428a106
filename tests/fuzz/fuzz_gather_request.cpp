// libFuzzer target: the request decoders of the service. The input is a
// serialized message as it comes off the wire; what the daemon does with
// a GatherRequest / RenderTileRequest / OpenSceneRequest before touching a
// scene must either succeed or throw a pbgi::Error (INVALID_ARGUMENT),
// never crash, hang or allocate without bound.
#include "common/errors.h"
#include "pbgi/v1/pbgi.pb.h"
#include "server/service/options_codec.h"
#include "server/service/receiver_codec.h"

#include <cstddef>
#include <cstdint>

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace pbgi;
  static const service::RequestDefaults defaults;
  v1::GatherRequest gather;
  if (gather.ParseFromArray(data, static_cast<int>(size))) {
    try {
      const auto receivers = service::decode_receivers(gather.positions(), gather.normals(), 1u << 16);
      (void)receivers;
    } catch (const Error&) {
    }
    try {
      (void)service::decode_gather_options(gather.options(), defaults.render.gather);
    } catch (const Error&) {
    }
    try {
      (void)service::decode_render_options(gather.options(), defaults.render);
    } catch (const Error&) {
    }
  }
  v1::OpenSceneRequest open;
  if (open.ParseFromArray(data, static_cast<int>(size))) {
    try {
      (void)service::decode_open_options(open.build(), defaults.open);
    } catch (const Error&) {
    }
    try {
      (void)service::decode_stage_selection(open);
    } catch (const Error&) {
    }
  }
  return 0;
}
