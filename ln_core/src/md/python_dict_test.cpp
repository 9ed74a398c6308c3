#include <gtest/gtest.h>

#include "ln/md/message_definition.hpp"
#include "md/test_support.hpp"

namespace ln::md {
namespace {

using testing::DefinitionTree;

// The expected texts are what LN 2.9's manager answered for the same files.
TEST(PythonDictText, PlainDefinitionKeepsSpellingsAndCounts) {
  DefinitionTree tree;
  tree.write_all({
      {"lg/pt", "double x\nuint8_t flag\n"},
      {"lg/n", "# nested\ndefine pt_t as \"lg/pt\"\npt_t p[2]\nint i\nchar label[4]\nfloat f # comment\n"},
  });
  Library library(SearchPath::exactly({tree.root()}));
  EXPECT_EQ(python_dict_text(library.load("lg/n")),
            "{'fields': [['pt_t', 'p', 2], ['int', 'i', 1], ['char', 'label', 4], ['float', 'f', 1]], "
            "'resp_fields': [], 'defines': {'pt_t': [['double', 'x', 1], ['uint8_t', 'flag', 1]]}}");
}

TEST(PythonDictText, NestedDefinesComeDepthFirstInDefineOrder) {
  DefinitionTree tree;
  tree.write_all({
      {"lg/pt", "double x\nuint8_t flag\n"},
      {"lg/v", "uint8_t a\ndouble b[2]\nint16_t c\n"},
      {"lg/sub/outer", "define inner_t as \"lg/pt\"\ndefine third as \"lg/v\"\ninner_t in[2]\nthird v\nuint16_t k\n"},
      {"lg/nest",
       "define outer_t as \"lg/sub/outer\"\ndefine pt_t as \"lg/pt\"\nouter_t o\npt_t q\n"
       "float32_t g[2]\n"},
  });
  Library library(SearchPath::exactly({tree.root()}));
  EXPECT_EQ(python_dict_text(library.load("lg/nest")),
            "{'fields': [['outer_t', 'o', 1], ['pt_t', 'q', 1], ['float32_t', 'g', 2]], 'resp_fields': [], "
            "'defines': {'outer_t': [['inner_t', 'in', 2], ['third', 'v', 1], ['uint16_t', 'k', 1]], "
            "'inner_t': [['double', 'x', 1], ['uint8_t', 'flag', 1]], "
            "'third': [['uint8_t', 'a', 1], ['double', 'b', 2], ['int16_t', 'c', 1]], "
            "'pt_t': [['double', 'x', 1], ['uint8_t', 'flag', 1]]}}");
}

TEST(PythonDictText, ServicesListBothSectionsAndDynamicFields) {
  DefinitionTree tree;
  tree.write("s/echo", "service\nrequest\ndouble* values\nresponse\nchar* text\nuint32_t n\n");
  Library library(SearchPath::exactly({tree.root()}));
  EXPECT_EQ(python_dict_text(library.load("s/echo")),
            "{'fields': [['uint32_t', 'values_len', 1], ['double*', 'values', 1]], "
            "'resp_fields': [['uint32_t', 'text_len', 1], ['char*', 'text', 1], ['uint32_t', 'n', 1]], "
            "'defines': {}}");
}

}  // namespace
}  // namespace ln::md
