#include "client/bench/json_writer.h"

#include "common/errors.h"

#include <gtest/gtest.h>

#include <limits>

namespace pbgi::bench {
namespace {

TEST(JsonWriter, WritesNestedDocuments) {
  JsonWriter w;
  w.begin_object();
  w.field("name", "a\"b\\c\n");
  w.field("n", uint64_t{42});
  w.field("x", 0.25);
  w.field("nan", std::numeric_limits<double>::quiet_NaN());
  w.field("ok", true);
  w.key("list");
  w.begin_array();
  w.value(1.5);
  w.begin_object();
  w.end_object();
  w.begin_array();
  w.end_array();
  w.end_array();
  w.end_object();
  EXPECT_EQ(w.str(),
            "{\n  \"name\": \"a\\\"b\\\\c\\n\",\n  \"n\": 42,\n  \"x\": 0.25,\n  \"nan\": null,\n"
            "  \"ok\": true,\n  \"list\": [\n    1.5,\n    {},\n    []\n  ]\n}");
}

TEST(JsonWriter, EscapesControlCharacters) {
  EXPECT_EQ(json_quote(std::string("a\x01" "b", 3)), "\"a\\u0001b\"");
  EXPECT_EQ(json_quote("tab\there"), "\"tab\\there\"");
}

TEST(JsonWriter, RejectsMalformedUse) {
  JsonWriter a;
  a.begin_object();
  EXPECT_THROW(a.value(1.0), InvalidArgument);  // no key
  EXPECT_THROW(a.end_array(), InvalidArgument);
  EXPECT_THROW(a.str(), InvalidArgument);       // still open
  JsonWriter b;
  EXPECT_THROW(b.key("k"), InvalidArgument);    // not in an object
  b.begin_array();
  EXPECT_THROW(b.key("k"), InvalidArgument);
}

}  // namespace
}  // namespace pbgi::bench
