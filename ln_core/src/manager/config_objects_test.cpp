// The process, state and group sections of .lnc files, templates, list
// modifiers and the directives that shape names (config_objects.cpp and
// config.cpp).
#include <gtest/gtest.h>

#include <sched.h>
#include <signal.h>
#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <climits>
#include <initializer_list>

#include "manager/config.hpp"
#include "manager/test_support.hpp"

namespace ln::manager {
namespace {

using testing::TempDir;

class LncObjectsTest : public ::testing::Test {
 protected:
  LncSettings read(const std::string& text) { return read_lnc_text(text, dir.path() + "/robot.lnc", log); }

  std::string error_of(const std::string& text) {
    try {
      read(text);
    } catch (const ConfigError& e) {
      return e.what();
    }
    return "(no error)";
  }

  /// Reading `text` fails with an error that contains each of `parts`.
  ::testing::AssertionResult fails_with(const std::string& text, std::initializer_list<const char*> parts) {
    const std::string error = error_of(text);
    for (const char* part : parts)
      if (error.find(part) == std::string::npos)
        return ::testing::AssertionFailure() << "the error '" << error << "' does not contain '" << part << "'";
    return ::testing::AssertionSuccess();
  }
  ::testing::AssertionResult fails_with(const std::string& text, const char* part) { return fails_with(text, {part}); }

  std::size_t logged(const std::string& text) const {
    return static_cast<std::size_t>(std::count_if(
        lines.begin(), lines.end(), [&](const std::string& l) { return l.find(text) != std::string::npos; }));
  }

  static const ProcessConfig& process(const LncSettings& s, const std::string& name) {
    for (const auto& p : s.processes)
      if (p.name == name) return p;
    throw std::runtime_error("no process " + name);
  }
  static const GroupConfig& group(const LncSettings& s, const std::string& name) {
    for (const auto& g : s.groups)
      if (g.name == name) return g;
    throw std::runtime_error("no group " + name);
  }
  static std::string env(const ProcessConfig& p, const std::string& name) {
    for (const auto& [key, value] : p.environment)
      if (key == name) return value;
    return "<unset>";
  }
  static std::vector<std::string> names(const std::vector<Dependency>& list) {
    std::vector<std::string> out;
    for (const auto& d : list) {
      std::string joined = d.down ? "!" : "";
      for (const auto& c : d.candidates) joined += (joined.size() > (d.down ? 1u : 0u) ? "|" : "") + c;
      out.push_back(joined);
    }
    return out;
  }

  TempDir dir;
  std::vector<std::string> lines;
  LogFunction log = [this](LogLevel, const std::string& line) { lines.push_back(line); };
};

TEST_F(LncObjectsTest, ProcessKeysAreParsed) {
  const LncSettings s = read(
      "defines\n"
      "bin: /usr/bin\n"
      "process talker\n"
      "command: %(bin)/python3 -u talker.py --name %(_PROCESS)\n"
      "node: localhost\n"
      "environment: A=1, B=two\n"
      "pass_environment: HOME, LC_*\n"
      "change_directory: /tmp\n"
      "flags: no_error_on_successful_stop, no_pty\n"
      "ready_regex: ^ready \\d+\n"
      "ready_time: 1.5\n"
      "term_signal: INT\n"
      "term_timeout: 0.5\n"
      "auto_restart_interval: 2\n"
      "policy: SCHED_FIFO\n"
      "priority: 40\n"
      "affinity: 0,2\n"
      "nice: 5\n"
      "map_topic: old.topic => new.topic\n"
      "map_topic: a => b\n"
      "map_service: svc => other\n"
      "output_logfile: /tmp/talker.log\n"
      "output_logfile_size_limit: 2MB\n"
      "output_logfile_keep_count: 3\n"
      "max_output_lines: 50\n"
      "warning_regex: WARN\n"
      "set_resource_limits: RTPRIO=50, memlock=inf\n"
      "alt_command debug: /usr/bin/gdb --args %(bin)/python3\n"
      "description: [\n"
      "  speaks\n"
      "  a lot ]\n");
  ASSERT_EQ(s.processes.size(), 1u);
  const ProcessConfig& p = s.processes.front();
  EXPECT_EQ(p.name, "talker");
  EXPECT_EQ(p.display_name, "talker");
  EXPECT_EQ(p.place.line, 3);
  EXPECT_EQ(p.command, "/usr/bin/python3 -u talker.py --name talker");
  EXPECT_EQ(p.remote_host, "");
  EXPECT_EQ(env(p, "A"), "1");
  EXPECT_EQ(env(p, "B"), "two");
  EXPECT_EQ(p.pass_environment, (std::vector<std::string>{"HOME", "LC_*"}));
  EXPECT_EQ(p.change_directory, "/tmp");
  EXPECT_TRUE(p.has_flag("no_pty"));
  EXPECT_EQ(p.ready_regex, "^ready \\d+");
  EXPECT_EQ(p.ready_time, 1.5);
  EXPECT_EQ(p.term_signal, SIGINT);
  EXPECT_EQ(p.term_timeout, 0.5);
  EXPECT_EQ(p.auto_restart_interval, 2.0);
  EXPECT_EQ(p.policy, SCHED_FIFO);
  EXPECT_EQ(p.priority, 40);
  EXPECT_EQ(p.affinity, (std::vector<int>{0, 2}));
  EXPECT_EQ(p.nice, 5);
  EXPECT_EQ(p.map_topics.size(), 2u);
  EXPECT_EQ(p.map_topics.front(), (std::pair<std::string, std::string>{"old.topic", "new.topic"}));
  EXPECT_EQ(p.map_services.front(), (std::pair<std::string, std::string>{"svc", "other"}));
  EXPECT_EQ(p.output_logfile, "/tmp/talker.log");
  EXPECT_EQ(p.output_logfile_size_limit, 2u << 20);
  EXPECT_EQ(p.output_logfile_keep_count, 3u);
  EXPECT_EQ(p.max_output_lines, 50u);
  EXPECT_EQ(p.warning_regex, "WARN");
  ASSERT_EQ(p.resource_limits.size(), 2u);
  EXPECT_EQ(p.resource_limits[0].resource, RLIMIT_RTPRIO);
  EXPECT_EQ(p.resource_limits[0].value, 50);
  EXPECT_EQ(p.resource_limits[1].value, -1);
  ASSERT_EQ(p.alt_commands.size(), 1u);
  EXPECT_EQ(p.alt_commands.front().first, "debug");
  EXPECT_EQ(p.description, "speaks\na lot");
}

TEST_F(LncObjectsTest, ListModifiersAsLn29) {
  const LncSettings s = read(
      "process p\n"
      "command: /bin/true\n"
      "environment: PATH=/bin, KEEP=1\n"
      "append environment PATH: :/usr/bin\n"
      "prepend environment PATH: /opt/bin:\n"
      "append environment NEW: created\n"
      "add environment: KEEP=2\n"
      "add environment: ANOTHER=x\n"
      "remove environment ANOTHER: x\n"
      "flags: no_pty\n"
      "add flags: start_in_shell, use_execvpe\n"
      "add flag: no_pty\n"
      "del flags: use_execvpe\n"
      "command+: \" --more\"\n"
      "depends_on: q\n"
      "reset depends_on:\n"
      "process q\n"
      "command: /bin/true\n");
  const ProcessConfig& p = process(s, "p");
  EXPECT_EQ(env(p, "PATH"), "/opt/bin:/bin:/usr/bin");
  EXPECT_EQ(env(p, "NEW"), "created");
  EXPECT_EQ(env(p, "KEEP"), "2") << "add on a KEY=VALUE list replaces that KEY";
  EXPECT_EQ(env(p, "ANOTHER"), "");
  EXPECT_EQ(p.flags, (std::vector<std::string>{"no_pty", "start_in_shell"}));
  EXPECT_EQ(p.command, "/bin/true --more") << "values are stripped: a leading space needs quotes, as in LN 2.9";
  EXPECT_TRUE(p.depends_on.empty());
  EXPECT_TRUE(fails_with("process p\ncommand: x\nadd command: y\n", "robot.lnc:3: 'add command': only list keys"));
  EXPECT_TRUE(fails_with("process p\ncommmand: /bin/true\n", "robot.lnc:2: unknown key 'commmand' in process 'p'"));
}

TEST_F(LncObjectsTest, TemplatesWithArgumentsDefaultsAndNesting) {
  const LncSettings s = read(
      "defines\n"
      "python: /usr/bin/python3\n"
      "template base(dir=/srv)\n"
      "change_directory: %(dir)\n"
      "add flags: no_error_on_successful_stop\n"
      "template python(script, args=--fast)\n"
      "use_template: base()\n"
      "command: %(python) %(script) %(args)\n"
      "pass_environment: PYTHONPATH\n"
      "process a\n"
      "use_template: python(\"a.py\")\n"
      "process b\n"
      "use_template: python('b.py', \"--slow, really\")\n"
      "add flags: no_pty\n");
  const ProcessConfig& a = process(s, "a");
  EXPECT_EQ(a.command, "/usr/bin/python3 a.py --fast");
  EXPECT_EQ(a.change_directory, "/srv");
  EXPECT_TRUE(a.has_flag("no_error_on_successful_stop"));
  const ProcessConfig& b = process(s, "b");
  EXPECT_EQ(b.command, "/usr/bin/python3 b.py --slow, really");
  EXPECT_EQ(b.flags, (std::vector<std::string>{"no_error_on_successful_stop", "no_pty"}));
  EXPECT_TRUE(
      fails_with("process a\nuse_template: missing()\n", "robot.lnc:2: use_template: there is no template 'missing'"));
  EXPECT_TRUE(
      fails_with("template t(x)\ncommand: %(x)\nprocess a\nuse_template: t(1, 2)\n", "takes 1 argument(s), got 2"));
  EXPECT_TRUE(fails_with("template t()\nbogus_key: 1\nprocess a\nuse_template: t()\n",
                         {"robot.lnc:2: unknown key 'bogus_key'", "in template 't' used here"}));
  EXPECT_TRUE(fails_with("template t()\nuse_template: t()\nprocess a\nuse_template: t()\n", "too deeply"));
}

TEST_F(LncObjectsTest, DefaultTemplatesApplyUnlessAProcessOptsOut) {
  const LncSettings s = read(
      "template defaults()\n"
      "add environment: FROM_DEFAULT=1\n"
      "add_process_default_template: defaults()\n"
      "process a\n"
      "command: /bin/true\n"
      "process b\n"
      "command: /bin/true\n"
      "flags: no_default_templates\n");
  EXPECT_EQ(env(process(s, "a"), "FROM_DEFAULT"), "1");
  EXPECT_EQ(env(process(s, "b"), "FROM_DEFAULT"), "<unset>");
}

TEST_F(LncObjectsTest, NamePrefixesScopeNamesAndEndWithTheirFile) {
  dir.write("arm.lnc",
            "push_name_prefix: arm\n"
            "process driver\n"
            "command: /bin/true\n"
            "process ctrl\n"
            "command: /bin/echo %(_PROCESS) %(_FULL_PROCESS) %(this_name)\n"
            "depends_on: driver\n");
  const LncSettings s = read(
      "push_name_prefix: robot\n"
      "include arm.lnc\n"
      "process driver\n"
      "command: /bin/true\n"
      "pop_name_prefix\n"
      "process top\n"
      "command: /bin/true\n"
      "depends_on: robot/arm/ctrl\n");
  const ProcessConfig& ctrl = process(s, "robot/arm/ctrl");
  EXPECT_EQ(ctrl.display_name, "ctrl");
  EXPECT_EQ(ctrl.command, "/bin/echo ctrl robot/arm/ctrl ctrl");
  EXPECT_EQ(names(ctrl.depends_on), (std::vector<std::string>{"robot/arm/driver"})) << "the nearest scope first";
  EXPECT_NO_THROW(process(s, "robot/driver")) << "the include's prefix ended with it";
  EXPECT_EQ(names(process(s, "top").depends_on), (std::vector<std::string>{"robot/arm/ctrl"}));
  EXPECT_TRUE(fails_with("process x\ncommand: /bin/true\nprocess x\ncommand: /bin/true\n",
                         "robot.lnc:3: 'x' is defined twice"));
}

TEST_F(LncObjectsTest, DependenciesResolveNamesGlobsAndProviders) {
  const LncSettings s = read(
      "process cam_left\ncommand: /bin/true\n"
      "process cam_right\ncommand: /bin/true\n"
      "process sim\ncommand: /bin/true\nprovides: robot.state\n"
      "process hardware\ncommand: /bin/true\nprovides: robot.state\n"
      "process backup\ncommand: /bin/true\nprovides: robot.state:-1\n"
      "state network\ncheck: true\nup: true\n"
      "process viewer\n"
      "command: /bin/true\n"
      "depends_on: cam_*, robot.state, !network\n"
      "depends_on_restart: sim\n"
      "start_on_ready: cam_left\n"
      "start_before: cam_right\n");
  const ProcessConfig& viewer = process(s, "viewer");
  EXPECT_EQ(names(viewer.depends_on),
            (std::vector<std::string>{"cam_left", "cam_right", "hardware|sim|backup", "!network"}))
      << "the provider defined last wins; explicit priorities count";
  EXPECT_EQ(names(viewer.depends_on_restart), (std::vector<std::string>{"sim"}));
  EXPECT_EQ(viewer.start_before, (std::vector<std::string>{"cam_right"}));
  EXPECT_EQ(process(s, "hardware").provides, (std::vector<std::pair<std::string, double>>{{"robot.state", 1.0}}));
  EXPECT_TRUE(fails_with("process a\ncommand: /bin/true\ndepends_on: nobody\n",
                         "robot.lnc:3: process 'a': depends_on: there is no process, state or provider 'nobody'"));
  EXPECT_TRUE(fails_with("process a\ncommand: /bin/true\ndepends_on: !b\nprocess b\ncommand: /bin/true\n",
                         "only a state can be required DOWN"));
  EXPECT_TRUE(fails_with("state s\ncheck: true\nprocess a\ncommand: /bin/true\nstart_before: s\n", "is a state"));
}

TEST_F(LncObjectsTest, DependencyCyclesAreRefused) {
  EXPECT_TRUE(
      fails_with("process a\ncommand: /bin/true\ndepends_on: b\n"
                 "process b\ncommand: /bin/true\ndepends_on_restart: c\n"
                 "process c\ncommand: /bin/true\ndepends_on: a\n",
                 {"a dependency cycle", "a -> b -> c -> a"}));
  EXPECT_TRUE(fails_with("process a\ncommand: /bin/true\ndepends_on: a\n", "is this process itself"));
}

TEST_F(LncObjectsTest, GroupsExpandGlobsNestedGroupsAndExclusions) {
  const LncSettings s = read(
      "process arm/driver\ncommand: /bin/true\n"
      "process arm/ctrl\ncommand: /bin/true\n"
      "process arm/debug\ncommand: /bin/true\n"
      "process base\ncommand: /bin/true\n"
      "state net\ncheck: true\n"
      "group arm\nmembers: arm/*, !*/debug\n"
      "group all\nmembers: arm, base, net, all\n"
      "group maybe\nmembers: nothing*\nflags: allow_empty\n");
  EXPECT_EQ(group(s, "arm").members, (std::vector<std::string>{"arm/ctrl", "arm/driver"}));
  EXPECT_EQ(group(s, "all").members, (std::vector<std::string>{"arm/ctrl", "arm/driver", "base", "net"}))
      << "a nested group's exclusions count, and a group in itself adds nothing";
  EXPECT_TRUE(group(s, "maybe").members.empty());
  EXPECT_TRUE(fails_with("group g\nmembers: nothing\n", "robot.lnc:2: group 'g': members: nothing matches 'nothing'"));
}

TEST_F(LncObjectsTest, AutoGroupsFromNamePrefixes) {
  const LncSettings s = read(
      "instance\nname: x\nenable_auto_groups: true\n"
      "process robot/arm/driver\ncommand: /bin/true\n"
      "process robot/base\ncommand: /bin/true\n");
  EXPECT_EQ(group(s, "robot").members, (std::vector<std::string>{"robot/arm/driver", "robot/base"}));
  EXPECT_EQ(group(s, "robot/arm").members, (std::vector<std::string>{"robot/arm/driver"}));
}

TEST_F(LncObjectsTest, StatesAndTheirKeys) {
  const LncSettings s = read(
      "state net\n"
      "check: ip link show lo\n"
      "up: true\n"
      "down: false\n"
      "min_check_interval: 5\n"
      "auto_check_interval: 1.5\n"
      "flags: need_check_after_up\n"
      "provides: network\n"
      "state tunnel\n"
      "tcp_tunnel_exit_node: robot\n"
      "tcp_tunnel_exit_target: 10.0.0.1:22\n");
  ASSERT_EQ(s.states.size(), 2u);
  const StateConfig& net = s.states[0];
  EXPECT_EQ(net.check, "ip link show lo");
  EXPECT_EQ(net.min_check_interval, 5);
  EXPECT_EQ(net.auto_check_interval, 1.5);
  EXPECT_TRUE(net.has_flag("need_check_after_up"));
  EXPECT_EQ(net.provides.size(), 1u);
  EXPECT_NE(s.states[1].unsupported.find("tunnel"), std::string::npos);
}

TEST_F(LncObjectsTest, BadValuesNameTheKeyAndLine) {
  // A bad value for a process key: {the key line, a part of the error}.
  const std::pair<const char*, const char*> cases[] = {
      {"term_signal: SIGNOPE", "robot.lnc:3: process 'p': term_signal: 'SIGNOPE' is not a signal"},
      {"term_timeout: soon", "term_timeout: 'soon' is not a number of seconds"},
      {"ready_time: -1", "not a number of seconds"},
      {"priority: 200", "priority: '200' is not an integer from 0 to 99"},
      {"policy: SCHED_FAST", "is not a scheduling policy"},
      {"affinity: first", "not a list of CPU numbers"},
      {"ready_regex: (?=x)", "not a regular expression ln_core can match"},
      {"environment: NOEQUALS", "'NOEQUALS' is not NAME=VALUE"},
      {"map_topic: a -> b", "expected 'SEARCH => REPLACE'"},
      {"output_logfile_size_limit: huge", "not a size"},
      {"change_user_to: root", "change_user_to: is not supported"},
      {"set_resource_limits: SPEED=1", "not a resource limit"},
  };
  for (const auto& [key_line, part] : cases)
    EXPECT_TRUE(fails_with(std::string("process p\ncommand: /bin/true\n") + key_line + "\n", part));
}

TEST_F(LncObjectsTest, RemoteNodesLoadButAreMarked) {
  const LncSettings s = read(
      "node_map\n"
      "arm_pc: localhost\n"
      "camera: camera-host.example\n"
      "process local\ncommand: /bin/true\nnode: arm_pc\n"
      "process far\ncommand: /bin/true\nnode: camera\n");
  EXPECT_EQ(process(s, "local").remote_host, "");
  EXPECT_EQ(process(s, "far").remote_host, "camera-host.example");
  EXPECT_EQ(logged("ln_core's manager runs processes on its own host only"), 1u);
}

TEST_F(LncObjectsTest, IncludeGlobPipeIncludeAndRequiresVersion) {
  dir.write("parts/a.lnc", "process a\ncommand: /bin/true\n");
  dir.write("parts/sub/b.lnc", "process b\ncommand: /bin/true\n");
  dir.write("parts/sub/skip.lnc", "process skip\ncommand: /bin/true\n");
  const LncSettings s = read(
      "include_glob: parts/**/*.lnc !parts/sub/skip.lnc\n"
      "optional_include_glob: nothing/*.lnc\n"
      "pipe_include: printf 'process piped\\ncommand: /bin/true\\n'\n"
      "requires_version: 2.8\n");
  std::vector<std::string> got;
  for (const auto& p : s.processes) got.push_back(p.name);
  EXPECT_EQ(got, (std::vector<std::string>{"a", "b", "piped"}));
  EXPECT_TRUE(fails_with("include_glob: nothing/*.lnc\n", "robot.lnc:1: include_glob: no file matches"));
  EXPECT_TRUE(fails_with("pipe_include: exit 4\n", "failed with exit status 4"));
  EXPECT_TRUE(fails_with("requires_version: 3.0.1\n", "requires an ln_manager of version 3.0.1"));
}

// `ln_manager -c robot.lnc` in the config's directory: patterns are relative
// to that directory, as the file name is.
TEST_F(LncObjectsTest, IncludeGlobOfAConfigNamedRelatively) {
  dir.write("parts/a.lnc", "process a\ncommand: /bin/true\n");
  const std::string text = "include_glob: parts/*.lnc\n";
  char before[PATH_MAX];
  ASSERT_NE(::getcwd(before, sizeof before), nullptr);
  ASSERT_EQ(::chdir(dir.path().c_str()), 0);
  std::string error;
  std::vector<std::string> got;
  try {
    for (const auto& p : read_lnc_text(text, "robot.lnc", log).processes) got.push_back(p.name);
  } catch (const ConfigError& e) {
    error = e.what();
  }
  ASSERT_EQ(::chdir(before), 0);
  EXPECT_EQ(error, "");
  EXPECT_EQ(got, (std::vector<std::string>{"a"}));
}

}  // namespace
}  // namespace ln::manager
