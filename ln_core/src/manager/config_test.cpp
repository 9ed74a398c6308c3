#include "manager/config.hpp"

#include <gtest/gtest.h>

#include <cstdlib>

#include "manager/test_support.hpp"

namespace ln::manager {
namespace {

using testing::TempDir;

class ConfigTest : public ::testing::Test {
 protected:
  LncSettings read(const std::string& text, const std::string& instance_name = "") {
    return read_lnc_text(text, dir.path() + "/test.lnc", log, instance_name);
  }

  // The ConfigError's text for `text`, or "" if it is accepted.
  std::string error_of(const std::string& text) {
    try {
      read(text);
    } catch (const ConfigError& e) {
      return e.what();
    }
    return "";
  }

  std::size_t logged(const std::string& text) const {
    std::size_t n = 0;
    for (const auto& line : lines) n += line.find(text) != std::string::npos;
    return n;
  }

  TempDir dir;
  std::vector<std::string> lines;
  LogFunction log = [this](LogLevel, const std::string& line) { lines.push_back(line); };
};

TEST_F(ConfigTest, ReadsTheInstanceSection) {
  const LncSettings s = read(
      "# minimal LN config\n"
      "instance\n"
      "name: lnref_test\n"
      "manager: :54414\n"
      "gen_message_definition_path: /tmp/gen_mds\n"
      "add_message_definition_dir: %(CURDIR)/msgdefs\n");
  EXPECT_EQ(s.instance_name, "lnref_test");
  EXPECT_EQ(s.manager_host, "");
  EXPECT_EQ(s.manager_port, 54414);
  EXPECT_EQ(s.generated_definition_dir, "/tmp/gen_mds");
  EXPECT_EQ(s.message_definition_dirs, std::vector<std::string>{dir.path() + "/msgdefs"});
  EXPECT_EQ(logged("does not exist"), 1u) << "a missing definition directory is worth a warning";
}

TEST_F(ConfigTest, ManagerHostAndPortAndInstanceOverride) {
  const LncSettings s = read("instance\nname: mine\nmanager: 0.0.0.0:0\n", "override");
  EXPECT_EQ(s.manager_host, "0.0.0.0");
  EXPECT_EQ(s.manager_port, 0);
  EXPECT_EQ(s.instance_name, "override");
  EXPECT_NE(error_of("instance\nmanager: localhost\n").find("test.lnc:2: manager:"), std::string::npos);
  EXPECT_NE(error_of("instance\nmanager: :70000\n").find("not a port number"), std::string::npos);
}

TEST_F(ConfigTest, EvaluatesDefinesEnvAndBuiltIns) {
  ::setenv("LN_CONFIG_TEST_VAR", "from_env", 1);
  ::unsetenv("LN_CONFIG_TEST_UNSET");
  const LncSettings s = read(
      "defines\n"
      "robot: rollin\n"
      "rollin_name: justin\n"
      "nested: %(%(robot)_name)\n"
      "env_value: %(env LN_CONFIG_TEST_VAR)\n"
      "env_default: %(env LN_CONFIG_TEST_UNSET, fallback value)\n"
      "instance\n"
      "name: %(nested)-%(env_value)-%(env_default)\n"
      "manager: :%(get_port_from_string %(instance_name))\n"
      "gen_message_definition_path: %(CURDIR)/gen/%(instance_name)\n");
  EXPECT_EQ(s.instance_name, "justin-from_env-fallback value");
  unsigned sum = 0;
  for (unsigned char c : std::string("justin-from_env-fallback value")) sum += c;
  EXPECT_EQ(s.manager_port, 1024 + sum % 64511);
  EXPECT_EQ(s.generated_definition_dir, dir.path() + "/gen/justin-from_env-fallback value");
}

TEST_F(ConfigTest, CommentsQuotesAndMultiLineBlocks) {
  const LncSettings s = read(
      "defines\n"
      "   # an indented comment\n"
      "quoted: \"value # not a comment\"\n"
      "block: [\n"
      "  first\n"
      "  # dropped\n"
      "  second ]\n"
      "instance\n"
      "name: %(quoted)/%(block) # a trailing comment\n"
      "\n");
  EXPECT_EQ(s.instance_name, "value # not a comment/first second");
}

TEST_F(ConfigTest, UnsupportedSectionsAndKeysAreReportedOnce) {
  const LncSettings s = read(
      "instance\n"
      "name: test\n"
      "documentation: http://example.org\n"
      "documentation: again\n"
      "hosts\n"
      "robot: arch:x86_64\n"
      "a line without colon inside an ignored section\n"
      "network lab\n"
      "member_interfaces: robot/eth0\n"
      "process talker\n"
      "command: /bin/true\n"
      "vte_color_style: dark\n"
      "add flags: forward_x11\n"
      "process listener\n"
      "command: /bin/true\n"
      "vte_color_style: light\n"
      "flags: forward_x11, no_such_flag\n");
  EXPECT_EQ(s.instance_name, "test");
  EXPECT_EQ(logged("the section type 'hosts' is not supported"), 1u);
  EXPECT_EQ(logged("test.lnc:5: the section type 'hosts'"), 1u) << "the report says where";
  EXPECT_EQ(logged("the section type 'network' is not supported"), 1u);
  EXPECT_EQ(logged("the instance key 'documentation' is not supported"), 1u);
  EXPECT_EQ(logged("the process key 'vte_color_style' is not supported"), 1u);
  EXPECT_EQ(logged("the flag 'forward_x11' is not supported"), 1u);
  EXPECT_EQ(logged("unknown flag 'no_such_flag'"), 1u);
  ASSERT_EQ(s.processes.size(), 2u);
}

TEST_F(ConfigTest, IncludesAreRelativeToTheIncludingFile) {
  dir.write("sub/part.lnc", "defines\nfrom_part: %(CURDIR)\n");
  const LncSettings s = read(
      "include sub/part.lnc\n"
      "optional_include: does/not/exist.lnc\n"
      "instance\n"
      "name: %(from_part)\n");
  EXPECT_EQ(s.instance_name, dir.path() + "/sub");
  EXPECT_NE(error_of("include missing.lnc\n").find("test.lnc:1: cannot include"), std::string::npos);
  dir.write("loop.lnc", "include loop.lnc\n");
  EXPECT_NE(error_of("include loop.lnc\n").find("nested too deeply"), std::string::npos);
}

TEST_F(ConfigTest, IfdefAndIfndefPrefixes) {
  const LncSettings s = read(
      "defines\n"
      "sim: 1\n"
      "empty:\n"
      "instance\n"
      "ifdef sim: name: simulated\n"
      "ifndef sim: name: real\n"
      "ifdef empty: manager: :1\n"
      "ifndef empty: manager: :2\n"
      "ifdef nothing: add_message_definition_dir: /never\n"
      "ifdef nothing: state skipped\n"
      "ifdef nothing: documentation: [\n"
      "  still consumed ]\n");
  EXPECT_EQ(s.instance_name, "simulated");
  EXPECT_EQ(s.manager_port, 2);
  EXPECT_TRUE(s.message_definition_dirs.empty());
  EXPECT_TRUE(s.states.empty());
}

TEST_F(ConfigTest, UndefAndWarningDirectives) {
  const LncSettings s = read(
      "defines\n"
      "x: 1\n"
      "undef: x\n"
      "warning: about %(CURRENT)\n"
      "instance\n"
      "ifndef x: name: undefined\n");
  EXPECT_EQ(s.instance_name, "undefined");
  EXPECT_EQ(logged("about " + dir.path() + "/test.lnc"), 1u);
}

TEST_F(ConfigTest, ErrorsNameFileAndLine) {
  EXPECT_NE(error_of("name: x\n").find("test.lnc:1: 'name:' appears before any section"), std::string::npos);
  EXPECT_NE(error_of("garbage here\n").find("test.lnc:1: expected a section"), std::string::npos);
  EXPECT_NE(error_of("instance\nname x\n").find("test.lnc:2: expected 'key: value'"), std::string::npos);
  EXPECT_NE(error_of("defines\na: [\n  never closed\n").find("test.lnc:2: the '[' block"), std::string::npos);
  EXPECT_NE(error_of("instance\nname: %(undefined)\n").find("test.lnc:2: there is no define 'undefined'"),
            std::string::npos);
  EXPECT_NE(error_of("instance\nname: %(unclosed\n").find("test.lnc:2: '%(' without"), std::string::npos);
  EXPECT_NE(error_of("instance\nname: %(env LN_CONFIG_TEST_UNSET)\n").find("is not set"), std::string::npos);
  EXPECT_NE(
      error_of("instance\nname: %(no_such_function x)\n").find("test.lnc:2: there is no function 'no_such_function'"),
      std::string::npos);
  EXPECT_NE(error_of("ifdef x\n").find("expected 'ifdef DEFINE: line'"), std::string::npos);
}

TEST_F(ConfigTest, ADefineThatCannotBeEvaluatedOnlyFailsWhereUsed) {
  ::unsetenv("LN_CONFIG_TEST_UNSET");
  EXPECT_EQ(error_of("defines\nhost: %(env LN_CONFIG_TEST_UNSET)\ninstance\nname: fine\n"), "");
  EXPECT_EQ(logged("define 'host' cannot be evaluated"), 1u);
  EXPECT_NE(error_of("defines\nhost: %(env LN_CONFIG_TEST_UNSET)\ninstance\nname: %(host)\n")
                .find("test.lnc:4: define 'host' is unusable"),
            std::string::npos);
}

TEST_F(ConfigTest, ReadsFilesAndReportsMissingOnes) {
  const std::string file = dir.write("real.lnc", "instance\nname: from_file\n");
  EXPECT_EQ(read_lnc_file(file, log).instance_name, "from_file");
  EXPECT_THROW(read_lnc_file(dir.path() + "/none.lnc", log), ConfigError);
}

TEST(SplitHostPort, AcceptsEmptyHostsAndRejectsBadPorts) {
  EXPECT_EQ(split_host_port(":54414"), (std::pair<std::string, std::uint16_t>{"", 54414}));
  EXPECT_EQ(split_host_port("127.0.0.1:0"), (std::pair<std::string, std::uint16_t>{"127.0.0.1", 0}));
  EXPECT_THROW(split_host_port("host"), std::invalid_argument);
  EXPECT_THROW(split_host_port("host:"), std::invalid_argument);
  EXPECT_THROW(split_host_port("host:x1"), std::invalid_argument);
  EXPECT_THROW(split_host_port("host:65536"), std::invalid_argument);
}

}  // namespace
}  // namespace ln::manager
