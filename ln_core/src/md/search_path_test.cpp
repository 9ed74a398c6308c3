#include <gtest/gtest.h>
#include <stdlib.h>

#include "ln/md/message_definition.hpp"
#include "md/test_support.hpp"

namespace ln::md {
namespace {

using testing::DefinitionTree;

TEST(SearchPath, FirstDirectoryWinsAndMissingDirectoriesAreDropped) {
  DefinitionTree tree;
  tree.write_all({
      {"one/x/def", "double a\n"},
      {"two/x/def", "double b\n"},
      {"two/x/only_two", "double c\n"},
  });
  const SearchPath path = SearchPath::exactly({tree.root() + "/one", tree.root() + "/absent", tree.root() + "/two"});
  EXPECT_EQ(path.dirs(), (std::vector<std::string>{tree.root() + "/one", tree.root() + "/two"}));
  EXPECT_EQ(*path.find("x/def"), tree.root() + "/one/x/def");
  EXPECT_EQ(*path.find("x/only_two"), tree.root() + "/two/x/only_two");
  EXPECT_FALSE(path.find("x/none"));
}

TEST(SearchPath, ExpandsMdConfFilesTransitively) {
  DefinitionTree tree;
  tree.write_all({
      {"base/md.conf", "# more definitions\n../extra\n\n"},
      {"extra/md.conf", tree.root() + "/deeper\n"},
      {"deeper/p/def", "double a\n"},
  });
  const SearchPath path = SearchPath::exactly({tree.root() + "/base"});
  ASSERT_EQ(path.dirs().size(), 3u);
  EXPECT_EQ(path.dirs()[1], tree.root() + "/extra");
  EXPECT_EQ(*path.find("p/def"), tree.root() + "/deeper/p/def");
}

TEST(SearchPath, StandardOrderPutsExplicitDirsFirstAndAppendsTheEnvironment) {
  DefinitionTree tree;
  tree.write_all({
      {"explicit/x", "double a\n"},
      {"from_env/x", "double b\n"},
      {"from_env/y", "double c\n"},
  });
  ::setenv("LN_MESSAGE_DEFINITION_DIRS", (tree.root() + "/from_env:").c_str(), 1);
  const SearchPath path = SearchPath::standard({tree.root() + "/explicit"});
  ::unsetenv("LN_MESSAGE_DEFINITION_DIRS");
  EXPECT_EQ(path.dirs().front(), tree.root() + "/explicit");
  EXPECT_EQ(path.dirs().back(), tree.root() + "/from_env");
  EXPECT_EQ(*path.find("x"), tree.root() + "/explicit/x");
  EXPECT_EQ(*path.find("y"), tree.root() + "/from_env/y");
}

TEST(SearchPath, RescanPicksUpNewDirectories) {
  DefinitionTree tree;
  tree.write("base/placeholder", "double a\n");
  SearchPath path = SearchPath::exactly({tree.root() + "/base", tree.root() + "/later"});
  EXPECT_EQ(path.dirs().size(), 1u);
  tree.write("later/z", "double a\n");
  path.rescan();
  EXPECT_EQ(*path.find("z"), tree.root() + "/later/z");
}

TEST(DefinitionNames, ValidationAndIdentifiers) {
  EXPECT_TRUE(is_valid_definition_name("a/b/c"));
  EXPECT_TRUE(is_valid_definition_name("two_doubles"));
  for (const char* bad : {"", "/abs", "a//b", "a/../b", "..", "a/", "./a"})
    EXPECT_FALSE(is_valid_definition_name(bad)) << bad;
  EXPECT_EQ(identifier_from_name("elevator/request/elevator_call"), "elevator_request_elevator_call");
  EXPECT_EQ(identifier_from_name("a.b c//d_"), "a_b_c_d");
}

}  // namespace
}  // namespace ln::md
