// The options tables agree with the wire contract: every entry's proto
// field exists with the entry's name and a type its value converts to,
// every field of the options messages has an entry, and every option,
// changed alone, survives encode -> decode.
#include "server/service/options_codec.h"
#include "server/service/proto_options.h"
#include "tests/support/perturbed_option.h"

#include <gtest/gtest.h>

#include <set>
#include <string>

namespace pbgi::service {
namespace {

namespace pb = google::protobuf;

// The proto field names a table covers (sub-messages by their own names).
template <class Table>
void covered(const Table& table, std::set<std::string>& names) {
  options::for_each_entry(table, [&](const auto& entry) {
    if constexpr (options::is_nest_v<decltype(entry)>) {
      if (entry.proto == 0) {
        covered(entry.table, names);
      } else {
        names.insert(std::string(entry.name));
      }
    } else if (entry.spec.proto != 0) {
      names.insert(std::string(entry.name));
    }
  });
}

std::set<std::string> message_fields(const pb::Descriptor* d) {
  std::set<std::string> names;
  for (int i = 0; i < d->field_count(); ++i) names.insert(std::string(d->field(i)->name()));
  return names;
}

TEST(OptionTables, EveryOptionsMessageFieldHasAnEntry) {
  std::set<std::string> render, open, fog;
  covered(kRenderOptionTable, render);
  covered(kOpenOptionTable, open);
  covered(kFogOptionTable, fog);
  EXPECT_EQ(render, message_fields(v1::GatherOptions::descriptor()));
  EXPECT_EQ(open, message_fields(v1::BuildOptions::descriptor()));
  EXPECT_EQ(fog, message_fields(v1::FogOptions::descriptor()));
}

// Each option changed alone, encoded and decoded over the defaults: the
// change arrives (so the entry's number, name and type fit its field).
template <class Table, class S, class Encode, class Decode>
void expect_each_option_round_trips(const Table& table, Encode encode, Decode decode) {
  int checked = 0;
  options::for_each_field(table, [&](const auto& probe) {
    if (probe.spec.proto == 0) return;
    S changed;
    options::for_each_value(
        table,
        [&](const auto& f, auto& values) {
          if constexpr (std::is_same_v<std::remove_cvref_t<decltype(f)>, std::remove_cvref_t<decltype(probe)>>) {
            if (f.name == probe.name && f.get == probe.get) f.set(values, testing::perturbed(f.get(values)));
          }
        },
        changed);
    ASSERT_FALSE(options::equal(table, changed, S())) << probe.name;
    EXPECT_TRUE(options::equal(table, decode(encode(changed)), changed)) << probe.name;
    ++checked;
  });
  EXPECT_GT(checked, 5);
}

TEST(OptionTables, EachOptionSurvivesTheWire) {
  expect_each_option_round_trips<decltype(kRenderOptionTable), RenderOptions>(
      kRenderOptionTable, encode_render_options,
      [](const v1::GatherOptions& p) {
        RenderOptions out;
        decode_fields(kRenderOptionTable, p, out);  // unvalidated: perturbed values may be out of range
        return out;
      });
  expect_each_option_round_trips<decltype(kOpenOptionTable), OpenOptions>(
      kOpenOptionTable, encode_open_options, [](const v1::BuildOptions& p) {
        OpenOptions out;
        decode_fields(kOpenOptionTable, p, out);
        return out;
      });
}

TEST(OptionTables, ProtoEnumsNameTheCppValues) {
  for (const auto& n : options::names_of<GatherMethod>()) {
    v1::GatherOptions p;
    GatherOptions g;
    g.method = n.value;
    RenderOptions r;
    r.gather = g;
    EXPECT_EQ(decode_render_options(encode_render_options(r), RenderOptions()).gather.method, n.value) << n.name;
  }
  v1::GatherOptions p;
  p.set_interpolation(v1::GatherOptions::INTERPOLATION_OFF);
  EXPECT_EQ(decode_render_options(p, RenderOptions()).interpolation.mode, InterpolationMode::kOff);
  p.set_method(v1::GatherOptions::FPBGI);
  EXPECT_EQ(decode_render_options(p, RenderOptions()).gather.method, GatherMethod::kFpbgi);
}

}  // namespace
}  // namespace pbgi::service
