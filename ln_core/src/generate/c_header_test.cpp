#include "generate/c_header.hpp"

#include <gtest/gtest.h>

#include "md/test_support.hpp"

namespace ln::generate {
namespace {

using md::testing::DefinitionTree;

std::size_t count(const std::string& haystack, const std::string& needle) {
  std::size_t n = 0;
  for (auto pos = haystack.find(needle); pos != std::string::npos; pos = haystack.find(needle, pos + 1)) ++n;
  return n;
}

class CHeader : public ::testing::Test {
 protected:
  void SetUp() override {
    tree.write("geo/point", "double x\ndouble y\n");
    tree.write("geo/path", "define point as \"point\"\npoint waypoints[8]\nuint32_t n\n");
    tree.write("elevator/request/elevator_call",
               "service\nrequest\nint32_t target_floor\nresponse\nint32_t reached_floor\nchar* error_message\n");
    tree.write("robot/moves", "service\nrequest\ndefine point as \"geo/point\"\npoint* targets\n");
    tree.write("robot/alarm", "event\nconnect\nuint8_t level\ncall\ndouble when\n");
  }
  std::string emit(const std::vector<std::string>& names, const CHeaderOptions& options = {}) {
    std::vector<const md::Definition*> defs;
    for (const auto& n : names) defs.push_back(&library.load(n));
    return emit_c_header(defs, options);
  }
  DefinitionTree tree;
  md::Library library{md::SearchPath::exactly({tree.root()})};
};

TEST_F(CHeader, EmitsEachTypeOnceWithImportsFirst) {
  const std::string h = emit({"geo/path", "robot/moves", "geo/point"});
  EXPECT_EQ(count(h, "struct LN_PACKED geo_point_struct {"), 1u);
  EXPECT_LT(h.find("geo_point_struct {"), h.find("geo_path_struct {"));
  EXPECT_NE(h.find("\tgeo_point_t waypoints[8];\n"), std::string::npos);
  EXPECT_NE(h.find("#define GEO_PATH_MD_NAME \"geo/path|" + library.load("geo/path").hash + "\""), std::string::npos);
  EXPECT_NE(h.find("\t\tuint32_t targets_len;\n\t\tgeo_point_t* targets;\n"), std::string::npos);
  // Topic types also get the documented C++ alias NAMESPACE::NAME_t.
  EXPECT_NE(h.find("namespace geo {\ntypedef ::geo_path_t path_t;"), std::string::npos);
  EXPECT_EQ(h.rfind("#ifndef LN_MESSAGES_H\n#define LN_MESSAGES_H\n", 0), 0u);
}

TEST_F(CHeader, GuardsEachTypeSoHeadersSharingATypeCombine) {
  const std::string h = emit({"geo/path"});
  EXPECT_NE(h.find("#ifndef GEO_POINT_MD_NAME\n/* geo/point */\n#define GEO_POINT_MD_NAME"), std::string::npos);
  EXPECT_NE(h.find("#endif  /* GEO_POINT_MD_NAME */"), std::string::npos);
}

TEST_F(CHeader, EmitsLn29ServiceNamesAndBaseClass) {
  const std::string h = emit({"elevator/request/elevator_call"});
  for (const char* expected :
       {"#define ELEVATOR_REQUEST_ELEVATOR_CALL_SIGNATURE \"int32_t 4 1|int32_t 4 1,uint32_t 4 1,char* 1 1\"",
        "#define elevator_request_elevator_call_signature ELEVATOR_REQUEST_ELEVATOR_CALL_SIGNATURE",
        "struct LN_PACKED elevator_request_elevator_call_request_t {",
        "struct LN_PACKED elevator_request_elevator_call_response_t {", "} req;", "} resp;",
        "typedef elevator_request_elevator_call_request_t request_t;", "} elevator_request_elevator_call_t;",
        "namespace elevator {\nnamespace request {", "typedef ::elevator_request_elevator_call_t elevator_call_t;",
        "class elevator_call_base {",
        "void register_elevator_call(::ln::client* clnt, const std::string service_name,\n\t\tconst char* group_name = "
        "NULL)",
        "void unregister_elevator_call()",
        "virtual int on_elevator_call(::ln::service_request& req, elevator_call_t& data) = 0;",
        "get_service_provider(service_name, \"elevator/request/elevator_call\", "
        "elevator_request_elevator_call_signature)",
        "memset(&data.resp, 0, sizeof(data.resp));", "#ifdef LN_MD_PREFIX_NS\nnamespace LN_MD_PREFIX_NS {"})
    EXPECT_NE(h.find(expected), std::string::npos) << expected;
}

TEST_F(CHeader, AppliesNamingOptions) {
  CHeaderOptions options;
  options.service_base_names["elevator/request/elevator_call"] = "call";
  options.wrapping_namespaces = {"outer"};
  options.prefix_namespace_define = "MY_PREFIX";
  options.guard = guard_for_output("gen/my-msgs.h");
  const std::string h = emit({"elevator/request/elevator_call"}, options);
  EXPECT_NE(h.find("class call_base {"), std::string::npos);
  EXPECT_NE(h.find("register_call("), std::string::npos);
  EXPECT_NE(h.find("namespace outer {\nnamespace elevator {"), std::string::npos);
  EXPECT_NE(h.find("#ifdef MY_PREFIX\nnamespace MY_PREFIX {"), std::string::npos);
  EXPECT_NE(h.find("#ifndef MY_MSGS_H"), std::string::npos);
  EXPECT_EQ(guard_for_output("ln_messages.h"), "LN_MESSAGES_H");
}

TEST_F(CHeader, EmitsEvents) {
  const std::string h = emit({"robot/alarm"});
  EXPECT_NE(h.find("#define ROBOT_ALARM_CONNECT_SIGNATURE \"robot/alarm: uint8_t 1 1\""), std::string::npos);
  EXPECT_NE(h.find("#define ROBOT_ALARM_CALL_SIGNATURE \"robot/alarm: double 8 1\""), std::string::npos);
  EXPECT_NE(h.find("} robot_alarm_connect_t;"), std::string::npos);
  EXPECT_NE(h.find("} robot_alarm_call_t;"), std::string::npos);
  EXPECT_NE(
      h.find("void connect_to_alarm(::ln::client* clnt, const std::string event_name, alarm_connect_t* connect_data)"),
      std::string::npos);
}

}  // namespace
}  // namespace ln::generate
