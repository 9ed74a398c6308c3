#include "manager/lnc_eval.hpp"

#include <gtest/gtest.h>

#include <cstdlib>
#include <initializer_list>
#include <map>
#include <utility>

namespace ln::manager {
namespace {

class EvaluatorTest : public ::testing::Test {
 protected:
  std::string eval(const std::string& text) { return evaluator.evaluate(text); }
  std::string error_of(const std::string& text) {
    try {
      evaluator.evaluate(text);
    } catch (const EvaluationError& e) {
      return e.what();
    }
    return "(no error)";
  }

  // Each {text, result}: evaluating text gives result.
  void expect_evaluations(std::initializer_list<std::pair<const char*, const char*>> cases) {
    for (const auto& [text, result] : cases) EXPECT_EQ(eval(text), result) << text;
  }

  std::map<std::string, std::string> defines{
      {"robot", "rollin"}, {"rollin_name", "justin"}, {"empty", ""}, {"path", "/a/b/c.txt"}, {"spaced", "a b"}};
  Evaluator evaluator{[this](const std::string& name) -> std::optional<std::string> {
                        const auto it = defines.find(name);
                        if (it == defines.end()) return std::nullopt;
                        return it->second;
                      },
                      [](const std::string& node) { return node == "localhost" || node == "here"; }};
};

TEST_F(EvaluatorTest, DefinesNestAndEscapes) {
  expect_evaluations({
      {"plain text (with parens) 100%", "plain text (with parens) 100%"},
      {"%(robot)", "rollin"},
      {"%(%(robot)_name)-%(robot)", "justin-rollin"},
      {"x%(empty)y", "xy"},
      {"\\(not a group\\)", "(not a group)"},
  });
  EXPECT_EQ(error_of("%(nope)"), "there is no define 'nope'");
  EXPECT_NE(error_of("%(robot").find("without its closing ')'"), std::string::npos);
}

TEST_F(EvaluatorTest, PathAndStringFunctions) {
  expect_evaluations({
      {"%(dirname %(path))", "/a/b"},
      {"%(basename %(path))", "c.txt"},
      {"%(dirname c.txt)", ""},
      {"%(dirname /)", "/"},
      {"%(strip   padded   )", "padded"},
      {"%(length \"%(robot)\")", "6"},
      {"%(subst \"o\", \"0\", \"%(robot)\")", "r0llin"},
      {"%(substring \"abcdef\", \"2\")", "cdef"},
      {"%(substring \"abcdef\", \"1\", \"3\")", "bcd"},
      {"%(substring \"abcdef\", \"-2\")", "ef"},
      {"%(findstring \"ll\", \"rollin\")", "ll"},
      {"%(findstring \"xx\", \"rollin\")", ""},
      {"%(ifeq \"%(robot)\", \"rollin\", \"yes\", \"no\")", "yes"},
      {"%(ifeq \"a\", \"b\", \"yes\", \"no\")", "no"},
      {"%(ifndef \"robot\", \"other\")", "rollin"},
      {"%(ifndef \"unset_define\", \"other\")", "other"},
      {"%(ifexists \"/\", \"there\", \"missing\")", "there"},
      {"%(ifexists \"/no/such/path\", \"there\", \"missing\")", "missing"},
      {"%(realpath /usr/../usr)", "/usr"},
  });
  EXPECT_NE(error_of("%(subst \"a\", \"b\")").find("takes \"SEARCH\", \"REPLACE\", \"TEXT\""), std::string::npos);
  EXPECT_NE(error_of("%(substring \"abc\", \"x\")").find("not an integer"), std::string::npos);
}

TEST_F(EvaluatorTest, QuotedArgumentsKeepCommasAndParens) {
  EXPECT_EQ(eval("%(subst \",\", \";\", \"a,b,(c)\")"), "a;b;(c)");
  EXPECT_EQ(Evaluator::split_arguments("\"a\", \"b \\\" c\" ,\"\""), (std::vector<std::string>{"a", "b \\\" c", ""}));
  EXPECT_EQ(Evaluator::split_arguments("not, quoted"), (std::vector<std::string>{"not, quoted"}));
  EXPECT_THROW(Evaluator::split_arguments("\"unclosed"), EvaluationError);
  EXPECT_THROW(Evaluator::split_arguments("\"a\" \"b\""), EvaluationError);
}

TEST_F(EvaluatorTest, EnvironmentPortAndInterfaces) {
  ::setenv("LN_EVAL_TEST_VAR", "value", 1);
  ::unsetenv("LN_EVAL_TEST_UNSET");
  expect_evaluations({
      {"%(env LN_EVAL_TEST_VAR)", "value"},
      {"%(env \"LN_EVAL_TEST_UNSET\", \"fallback\")", "fallback"},
      {"%(env LN_EVAL_TEST_UNSET, fallback)", "fallback"},
  });
  EXPECT_EQ(error_of("%(env LN_EVAL_TEST_UNSET)"), "the environment variable 'LN_EVAL_TEST_UNSET' is not set");
  // LN's formula, and the quoted-list form joined by spaces as LN 2.9 does
  EXPECT_EQ(eval("%(get_port_from_string ab)"), std::to_string(1024 + (97 + 98) % 64511));
  EXPECT_EQ(eval("%(get_port_from_string \"a\", \"b\")"), std::to_string(port_from_string("a b")));
  expect_evaluations({
      {"%(ifip lo)", "127.0.0.1"},
      {"%(get_host_ifip \"localhost\", \"lo\")", "127.0.0.1"},
  });
  EXPECT_NE(error_of("%(get_host_ifip \"robot\", \"lo\")").find("'robot' is another host"), std::string::npos);
  EXPECT_EQ(eval("%(get_host_ip_reachable_from_host \"here\", \"localhost\")"), "127.0.0.1");
  EXPECT_NE(error_of("%(ifip no_such_interface0)").find("no interface"), std::string::npos);
}

TEST_F(EvaluatorTest, ShellRunsCommandsAndReportsFailures) {
  expect_evaluations({
      {"%(shell echo %(robot))", "rollin"},
      {"%(shell \"printf 'a\\nb\\n\\n'\")", "a\nb"},
  });
  EXPECT_NE(error_of("%(shell exit 3)").find("failed with exit status 3"), std::string::npos);
  EXPECT_NE(error_of("%(shell echo oops >&2)").find("oops"), std::string::npos);
  evaluator.set_shell_timeout(0.2);
  EXPECT_NE(error_of("%(shell sleep 5)").find("did not finish"), std::string::npos);
}

TEST_F(EvaluatorTest, UserDefinedFunctions) {
  evaluator.define_function("greet", "%(deffun \"who, how\", \"%(how) %(who) of %(robot)\")");
  EXPECT_EQ(eval("%(greet \"justin\", \"hello\")"), "hello justin of rollin");
  EXPECT_EQ(eval("%(greet \"justin\")"), " justin of rollin") << "missing arguments are empty";
  EXPECT_THROW(evaluator.define_function("bad", "%(deffun \"only one\")"), EvaluationError);
  EXPECT_TRUE(Evaluator::is_function_definition("  %(deffun \"a\", \"b\")"));
  EXPECT_FALSE(Evaluator::is_function_definition("%(env X)"));
}

TEST_F(EvaluatorTest, RecursionIsBounded) {
  defines["loop"] = "%(loop)";
  // the callback returns the raw text; the evaluator itself does not
  // re-evaluate define values, so this is a literal
  EXPECT_EQ(eval("%(loop)"), "%(loop)");
  std::string deep;
  for (int i = 0; i < 40; ++i) deep += "%(strip ";
  deep += "x";
  for (int i = 0; i < 40; ++i) deep += ")";
  EXPECT_NE(error_of(deep).find("nested too deeply"), std::string::npos);
}

TEST(SplitWords, QuotesAndEscapesLikeAShell) {
  EXPECT_EQ(split_words("  /bin/echo  a 'b c' \"d \\\" e\" f\\ g  "),
            (std::vector<std::string>{"/bin/echo", "a", "b c", "d \" e", "f g"}));
  EXPECT_EQ(split_words("x ''"), (std::vector<std::string>{"x", ""}));
  EXPECT_EQ(split_words("'a'\"b\"c"), (std::vector<std::string>{"abc"}));
  EXPECT_EQ(split_words("\"keep \\n as is\""), (std::vector<std::string>{"keep \\n as is"}));
  EXPECT_THROW(split_words("echo 'unclosed"), EvaluationError);
}

}  // namespace
}  // namespace ln::manager
