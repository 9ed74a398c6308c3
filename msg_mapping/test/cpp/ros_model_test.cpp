#include <gtest/gtest.h>

#include "msg_mapping/ros_model.hpp"
#include "test_support.hpp"

namespace msg_mapping {
namespace {

TEST(RosModel, ParsesFieldsConstantsDefaultsAndComments) {
  const RosMessage m = parse_msg("pkg", "Thing",
                                 "# file comment\n"
                                 "\n"
                                 "uint8 KIND=3   # a constant\n"
                                 "# before\n"
                                 "float64[3] position\n"
                                 "string<=8 name \"abc\"\n"
                                 "int32[<=4] values\n"
                                 "Other[] others   # same package\n"
                                 "  # indented: belongs to others\n"
                                 "geometry_msgs/Point p\n"
                                 "string<=3[2] tags\n");
  EXPECT_EQ(m.comments, std::vector<std::string>{"file comment"});
  ASSERT_EQ(m.constants.size(), 1u);
  EXPECT_EQ(m.constants[0].name, "KIND");
  EXPECT_EQ(m.constants[0].value, "3");
  ASSERT_EQ(m.fields.size(), 6u);
  EXPECT_EQ(m.fields[0].type.spelling(), "float64[3]");
  EXPECT_EQ(m.fields[0].comments, std::vector<std::string>{"before"});
  EXPECT_EQ(m.fields[1].type.string_bound, 8u);
  EXPECT_EQ(m.fields[1].default_value, "\"abc\"");
  EXPECT_EQ(m.fields[2].type.array, RosFieldType::Array::Bounded);
  EXPECT_EQ(m.fields[3].type.nested, "pkg/Other");
  EXPECT_EQ(m.fields[3].comments.back(), "indented: belongs to others");
  EXPECT_EQ(m.fields[4].type.nested, "geometry_msgs/Point");
  EXPECT_EQ(m.fields[5].type.spelling(), "string<=3[2]");
  // emit -> parse gives the same model
  const RosMessage again = parse_msg("pkg", "Thing", emit_msg(m));
  ASSERT_EQ(again.fields.size(), m.fields.size());
  for (std::size_t i = 0; i < m.fields.size(); ++i)
    EXPECT_EQ(again.fields[i].type.spelling(), m.fields[i].type.spelling());
}

TEST(RosModel, ParsesServices) {
  const RosService s = parse_srv("pkg", "Get", "string key\n---\nbool ok\nfloat32[] data\n");
  EXPECT_EQ(s.full_name(), "pkg/srv/Get");
  EXPECT_EQ(s.request.full_name(), "pkg/srv/Get_Request");
  EXPECT_EQ(s.response.fields.size(), 2u);
  EXPECT_THROW(parse_srv("pkg", "Bad", "string key\n"), Error);
}

TEST(RosModel, RejectsBadInput) {
  EXPECT_THROW(parse_msg("p", "T", "float64\n"), Error);
  EXPECT_THROW(parse_msg("p", "T", "float64 Bad\n"), Error);
  EXPECT_THROW(parse_msg("p", "T", "float64 a\nint8 a\n"), Error);
  EXPECT_THROW(parse_msg("p", "T", "float64[0] a\n"), Error);
  EXPECT_THROW(parse_msg("p", "T", "time stamp\n"), Error);
  EXPECT_THROW(parse_msg("p", "T", "not_a_type x\n"), Error);
  EXPECT_THROW(parse_msg("p", "T", "uint8 lower=1\n"), Error);
  try {
    parse_msg("p", "T", "int8 a\nfloat64 Bad\n");
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("p/msg/T:2"), std::string::npos) << e.what();
  }
}

TEST(RosModel, StoreFindsInstalledFiles) {
  RosTypeStore store({test::data_dir() + "/ros_share"});
  const RosMessage& m = store.message("mm_test_msgs/msg/Bounded");
  EXPECT_EQ(m.fields.front().name, "name");
  EXPECT_EQ(&m, &store.message("mm_test_msgs/Bounded"));
  EXPECT_EQ(store.service("mm_test_msgs/srv/Lookup").response.fields.size(), 3u);
  EXPECT_EQ(store.package_types("mm_test_msgs", "msg").size(), 3u);
  EXPECT_THROW(store.message("mm_test_msgs/msg/Missing"), Error);
  EXPECT_THROW(store.message("not a type"), Error);
}

}  // namespace
}  // namespace msg_mapping
