#include "manager/names.hpp"

#include <gtest/gtest.h>

#include <set>

namespace ln::manager {
namespace {

TEST(Names, AcceptsTopicNamesOfTheProposedRuleSet) {
  for (const char* name :
       {"a", "elevator03.sensors", "robot.joint_states", "ns:topic-1", "legacy name.x", "A.B.C.d_e-f:g"})
    EXPECT_FALSE(topic_name_problem(name)) << name;
  EXPECT_FALSE(topic_name_problem(std::string(127, 'x')));
}

TEST(Names, RejectsTopicNamesWithAClearReason) {
  struct Case {
    std::string name;
    std::string reason;
  };
  for (const Case& c : std::vector<Case>{{"", "empty"},
                                         {".a", "start or end with '.'"},
                                         {"a.", "start or end with '.'"},
                                         {"a..b", "'..'"},
                                         {"a/b", "'/'"},
                                         {"a/", "'/'"},
                                         {"a*b", "other than"},
                                         {"a\nb", "other than"},
                                         {" a", "space"},
                                         {std::string(128, 'x'), "limit is 127"}}) {
    const auto problem = topic_name_problem(c.name);
    ASSERT_TRUE(problem) << c.name;
    EXPECT_NE(problem->find(c.reason), std::string::npos) << *problem;
    EXPECT_EQ(problem->find('\n'), std::string::npos) << "control characters are masked: " << *problem;
  }
}

TEST(Names, ServiceNamesFollowTheSameRulesAndNeverAllowSlashes) {
  EXPECT_FALSE(service_name_problem("elevator.call"));
  ASSERT_TRUE(service_name_problem("elevator/call"));
  EXPECT_NE(service_name_problem("elevator/call")->find("service name"), std::string::npos);
  EXPECT_TRUE(service_name_problem(""));
}

TEST(Names, ClientNamesAreFreeTextWithoutControlCharacters) {
  EXPECT_FALSE(client_name_problem("my program (dbg) 1"));
  EXPECT_TRUE(client_name_problem(""));
  EXPECT_TRUE(client_name_problem("a\tb"));
  EXPECT_TRUE(client_name_problem(std::string(256, 'x')));
}

TEST(Names, DefinitionNamesCannotEscapeTheSearchPath) {
  EXPECT_FALSE(definition_name_problem("counter/count_message"));
  for (const char* name : {"", "/etc/passwd", "../x", "a/../b", "a//b", "a/./b", "a/"})
    EXPECT_TRUE(definition_name_problem(name)) << name;
}

TEST(Names, UniqueClientNamesAppendACounterLikeLn) {
  std::set<std::string> taken;
  auto is_taken = [&](const std::string& n) { return taken.count(n) > 0; };
  EXPECT_EQ(unique_client_name("dup", is_taken), "dup");
  taken.insert("dup");
  EXPECT_EQ(unique_client_name("dup", is_taken), "dup 1");
  taken.insert("dup 1");
  EXPECT_EQ(unique_client_name("dup", is_taken), "dup 2");
  taken.erase("dup 1");
  EXPECT_EQ(unique_client_name("dup", is_taken), "dup 1");
}

TEST(Names, SplitsNameAndHash) {
  EXPECT_EQ(split_name_and_hash("a/b|123"), (std::pair<std::string, std::string>{"a/b", "123"}));
  EXPECT_EQ(split_name_and_hash("a/b"), (std::pair<std::string, std::string>{"a/b", ""}));
}

}  // namespace
}  // namespace ln::manager
