#include <gtest/gtest.h>

#include <utility>

#include "msg_mapping/naming.hpp"
#include "msg_mapping/ros_model.hpp"

namespace msg_mapping {
namespace {

TEST(Naming, CamelToSnakeMatchesRosidl) {
  const std::pair<const char*, const char*> cases[] = {
      {"HTTPServer", "http_server"},   {"TreeInfo2", "tree_info2"},         {"numCounts", "num_counts"}, {"ABC", "abc"},
      {"PointCloud2", "point_cloud2"}, {"Pose2DStamped", "pose2_d_stamped"}};
  for (const auto& [camel, snake] : cases) EXPECT_EQ(camel_to_snake(camel), snake) << camel;
}

TEST(Naming, PackageAndTypeFromLnName) {
  const NamingOptions options;
  const struct {
    const char *ln_name, *package, *type;
  } cases[] = {{"ln/file_services2/tree_info2", "ln_ln_msgs", "FileServices2TreeInfo2"},
               {"two_doubles", "ln_msgs", "TwoDoubles"},
               {"MyRobot/arm-state.v2", "my_robot_ln_msgs", "ArmStateV2"},
               {"3d/9lives", "ln_3d_ln_msgs", "Ln9lives"}};
  for (const auto& c : cases) {
    const RosTypeName name = ros_type_name_for(c.ln_name, options);
    EXPECT_EQ(name.package, c.package) << c.ln_name;
    EXPECT_EQ(name.type, c.type) << c.ln_name;
  }
  RosTypeName n = ros_type_name_for("x/none", options);
  EXPECT_EQ(n.type,
            "None"
            "Msg");  // Python keyword
  NamingOptions single;
  single.single_package = "robot_interfaces";
  n = ros_type_name_for("ln/string", single);
  EXPECT_EQ(n.package, "robot_interfaces");
  EXPECT_EQ(n.type, "LnString");
}

TEST(Naming, UnmappableLnNamesAreErrors) {
  const NamingOptions options;
  EXPECT_THROW(ros_type_name_for("robot/pos\xc3\xa9", options), Error);
  EXPECT_THROW(ros_type_name_for("robot/a+b", options), Error);
  EXPECT_THROW(ros_type_name_for("__/x", options), Error);
  NamingOptions bad;
  bad.single_package = "Bad_Name_";
  EXPECT_THROW(ros_type_name_for("a/b", bad), Error);
  try {
    ros_type_name_for("robot/a+b", options);
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("'robot/a+b'"), std::string::npos);
    EXPECT_NE(std::string(e.what()).find("'+'"), std::string::npos);
  }
}

TEST(Naming, FieldNames) {
  std::string why;
  EXPECT_EQ(ros_field_name_for("string", &why), "string_field");
  EXPECT_NE(why.find("keyword"), std::string::npos);
  EXPECT_EQ(ros_field_name_for("numCounts", &why), "num_counts");
  EXPECT_EQ(ros_field_name_for("plain", &why), "plain");
  EXPECT_TRUE(why.empty());
  const std::pair<const char*, const char*> renamed[] = {{"_private", "private_field"},
                                                         {"a__b_", "a_b"},
                                                         {"_1", "field_1"},
                                                         {"True", "true_field"},
                                                         {"int8", "int8_field"}};
  for (const auto& [ln_name, ros_name] : renamed) EXPECT_EQ(ros_field_name_for(ln_name), ros_name) << ln_name;
  EXPECT_EQ(ln_field_name_for("default"), "default_field");
  EXPECT_EQ(ln_field_name_for("data"), "data");
}

TEST(Naming, RosidlPatterns) {
  EXPECT_TRUE(is_valid_ros_package_name("std_msgs"));
  EXPECT_FALSE(is_valid_ros_package_name("std__msgs"));
  EXPECT_FALSE(is_valid_ros_package_name("msgs_"));
  EXPECT_FALSE(is_valid_ros_package_name("1msgs"));
  EXPECT_TRUE(is_valid_ros_type_name("Pose2D"));
  EXPECT_FALSE(is_valid_ros_type_name("pose"));
  EXPECT_FALSE(is_valid_ros_type_name("Pose_2"));
  EXPECT_TRUE(is_valid_ros_constant_name("FLOAT64"));
  EXPECT_TRUE(is_valid_ros_constant_name("A_B"));
  EXPECT_FALSE(is_valid_ros_constant_name("A__B"));
  EXPECT_FALSE(is_valid_ros_constant_name("A_"));
}

}  // namespace
}  // namespace msg_mapping
