#include "client/launch_options.hpp"

#include <gtest/gtest.h>

#include "client/c_api.hpp"
#include "client/failure.hpp"
#include "client/name_mapping.hpp"

namespace ln::clientlib {
namespace {

CommandLine parse(std::vector<const char*> args) {
  return parse_command_line(static_cast<int>(args.size()), args.data());
}

TEST(CommandLine, TakesLnOptionsInBothSpellingsAndKeepsTheRest) {
  const CommandLine parsed =
      parse({"prog", "-x", "--ln-manager", "h:1", "file", "-ln_program_name", "n", "--ln-map-topic", "a", "b",
             "-ln_map_topic", "c", "d", "--ln-map-service", "s", "t", "tail"});
  EXPECT_EQ(parsed.manager_address, "h:1");
  EXPECT_EQ(parsed.program_name, "n");
  ASSERT_EQ(parsed.topic_mappings.size(), 2u);
  EXPECT_EQ(parsed.topic_mappings[1].source, "c");
  EXPECT_EQ(parsed.topic_mappings[1].destination, "d");
  ASSERT_EQ(parsed.service_mappings.size(), 1u);
  EXPECT_EQ(parsed.remaining, (std::vector<std::string>{"prog", "-x", "file", "tail"}));
}

TEST(CommandLine, OptionWithoutValueAtTheEndStays) {
  const CommandLine parsed = parse({"prog", "--ln-map-topic", "only_source"});
  EXPECT_TRUE(parsed.topic_mappings.empty());
  EXPECT_EQ(parsed.remaining, (std::vector<std::string>{"prog", "--ln-map-topic", "only_source"}));
  EXPECT_FALSE(parse({"prog", "--ln-manager"}).manager_address);
}

TEST(CommandLine, Argv0IsNeverAnOption) {
  const CommandLine parsed = parse({"--ln-manager", "x:1"});
  EXPECT_FALSE(parsed.manager_address);
  EXPECT_EQ(parsed.remaining.size(), 2u);
  EXPECT_TRUE(parse_command_line(0, nullptr).remaining.empty());
}

TEST(LaunchOptions, ExactNamesLeaveProgramNameOptionsInTheRemainingArguments) {
  std::vector<const char*> args{"prog", "--ln-program-name", "other", "--ln-manager", "h:1", "x"};
  const CommandLine parsed = parse_command_line(static_cast<int>(args.size()), args.data(), true);
  EXPECT_FALSE(parsed.program_name);
  EXPECT_EQ(parsed.manager_address, "h:1");
  EXPECT_EQ(parsed.remaining, (std::vector<std::string>{"prog", "--ln-program-name", "other", "x"}));
}

TEST(ManagerAddress, ExplicitWinsOverEnvironment) {
  EXPECT_EQ(choose_manager_address(std::string("a:1"), "b:2"), "a:1");
  EXPECT_EQ(choose_manager_address(std::nullopt, "b:2"), "b:2");
  EXPECT_EQ(choose_manager_address(std::string(""), "b:2"), "b:2");
  EXPECT_FALSE(choose_manager_address(std::nullopt, ""));
  EXPECT_FALSE(choose_manager_address(std::nullopt, nullptr));
}

TEST(ClientName, OverridesInLnOrder) {
  EXPECT_EQ(choose_client_name("code", nullptr, std::nullopt, "prog").name, "code");
  EXPECT_EQ(choose_client_name("code", "env", std::nullopt, "prog").name, "env");
  EXPECT_EQ(choose_client_name("code", "env", std::string("arg"), "prog").name, "arg");
  EXPECT_EQ(choose_client_name(nullptr, nullptr, std::nullopt, "prog").name, "prog");
  EXPECT_EQ(choose_client_name("", "", std::string(""), "prog").name, "prog");
}

TEST(ClientName, ExactIgnoresOverrides) {
  const RequestedName exact = choose_client_name("exact:robot", "env", std::string("arg"), "prog");
  EXPECT_TRUE(exact.exact);
  EXPECT_EQ(exact.name, "robot");
  EXPECT_FALSE(choose_client_name("robot", nullptr, std::nullopt, "p").exact);
}

TEST(NameMapping, PatternForms) {
  // One rule {search, replace} applied to `name`.
  const struct {
    const char* search;
    const char* replace;
    const char* name;
    const char* mapped;
  } cases[] = {
      {"^a.b$", "x", "a.b", "x"},  // the whole name
      {"^a.b$", "x", "a.b.c", "a.b.c"},
      {"^robot1.", "robot2.", "robot1.joints", "robot2.joints"},  // a prefix
      {"^robot1.", "robot2.", "my.robot1.joints", "my.robot1.joints"},
      {".state$", ".status", "arm.state", "arm.status"},  // a suffix
      {".state$", ".status", "arm.state.x", "arm.state.x"},
      {"sim", "real", "a.sim.b.sim", "a.real.b.sim"},  // anywhere: the first occurrence only
  };
  for (const auto& c : cases) {
    NameMapping mapping;
    mapping.add({c.search, c.replace});
    EXPECT_EQ(mapping.apply(c.name), c.mapped) << "'" << c.search << "' on '" << c.name << "'";
  }
}

TEST(NameMapping, RulesApplyInOrderCumulatively) {
  NameMapping mapping;
  mapping.add({"^a", "b"});
  mapping.add({"^b", "c"});
  EXPECT_EQ(mapping.apply("a.x"), "c.x");
}

TEST(NameMapping, FromEnvironmentPairs) {
  NameMapping mapping;
  mapping.add_from_environment("^in$|out|x|y|dangling");
  EXPECT_EQ(mapping.apply("in"), "out");
  EXPECT_EQ(mapping.apply("axb"), "ayb");
  EXPECT_EQ(mapping.apply("dangling"), "dangling");
}

TEST(ErrorText, LnStyleTexts) {
  EXPECT_STREQ(error_text(-LNE_NO_MANAGER_ADDRESS),
               "LNE_NO_MANAGER_ADDRESS - no --ln-manager HOST:PORT command line argument and no LN_MANAGER "
               "environment var");
  EXPECT_EQ(std::string(error_text(LNE_PACKET_TOO_LARGE)).rfind("LNE_PACKET_TOO_LARGE - ", 0), 0u);
  EXPECT_STREQ(error_text(0), "unknown error");
  EXPECT_STREQ(error_text(-70), "unknown error");
  EXPECT_STREQ(error_text(-1000000), "unknown error");
  remember_errno(ECONNREFUSED);
  EXPECT_EQ(std::string(error_text(-LNE_CHECK_ERRNO)), "errno 111 - Connection refused");
  for (int code = 1; code <= LNE_WRONG_MD_HASH; ++code) EXPECT_NE(error_text(-code), nullptr);
}

}  // namespace
}  // namespace ln::clientlib
