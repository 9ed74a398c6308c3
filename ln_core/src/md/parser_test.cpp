#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "ln/md/message_definition.hpp"
#include "md/test_support.hpp"

namespace ln::md {
namespace {

using testing::DefinitionTree;
using testing::load_error;

std::vector<std::string> names_of(const std::vector<Field>& fields) {
  std::vector<std::string> names;
  for (const auto& f : fields) names.push_back(f.name);
  return names;
}

TEST(Parser, ReadsEveryPrimitiveTypeAndKeepsAliasSpellings) {
  DefinitionTree tree;
  tree.write("t/all",
             "float a\nfloat32_t b\ndouble c\nfloat64_t d\nchar e\nint8_t f\nuint8_t g\n"
             "int16_t h\nshort i\nuint16_t j\nint32_t k\nint l\nuint32_t m\nint64_t n\nuint64_t o\n");
  Library library(SearchPath::exactly({tree.root()}));
  const Definition& def = library.load("t/all");
  EXPECT_EQ(def.kind, Kind::Plain);
  ASSERT_EQ(def.fields.size(), 15u);
  EXPECT_EQ(def.fields[1].type_spelling, "float32_t");
  EXPECT_EQ(*def.fields[1].primitive, Primitive::Float);
  EXPECT_EQ(def.fields[8].type_spelling, "short");
  EXPECT_EQ(c_name(*def.fields[8].primitive), "int16_t");
  EXPECT_EQ(c_name(*def.fields[11].primitive), "int32_t");
  EXPECT_EQ(packet_size(def), 4u + 4 + 8 + 8 + 1 + 1 + 1 + 2 + 2 + 2 + 4 + 4 + 4 + 8 + 8);
}

TEST(Parser, HashesTheWayLn29Does) {
  DefinitionTree tree;
  tree.write_all({
      {"counter/count_message", "double time\nuint32_t num_counts\n"},
      {"geo/pt", "float x\nfloat y\n"},
      {"geo/svc", "service\nrequest\ndefine pt as \"pt\"\ndouble* values\nresponse\nint n\n"},
  });
  Library library(SearchPath::exactly({tree.root()}));
  // sha256(repr(([['double', 'time', 1], ['uint32_t', 'num_counts', 1]], [], [])))
  EXPECT_EQ(library.load("counter/count_message").hash,
            "b46aeb52e96c7204cd02ce1b2508f520e3308d199a7f067acb470e53bdb788c9");
  // The implicit values_len, the alias spelling "int" and the imported
  // type's fields (keyed by its local name) all take part.
  EXPECT_EQ(library.load("geo/svc").hash, "094ea423b6f6bc3cd0f26741f14297665fa943ae3f983cd4d6d36aeb0c940640");
}

TEST(Parser, SplitsServicesAndEventsIntoSections) {
  DefinitionTree tree;
  tree.write_all({
      {"s/svc", "# leading comment\n\nservice\ndouble early\nresponse\nint32_t code\nrequest\ndouble late\n"},
      {"s/ev", "event\nconnect\nuint8_t filter\ncall\ndouble value\n"},
      {"s/plain_with_markers", "request x\n"},
  });
  Library library(SearchPath::exactly({tree.root()}));
  const Definition& svc = library.load("s/svc");
  EXPECT_EQ(svc.kind, Kind::Service);
  EXPECT_EQ(names_of(svc.fields), (std::vector<std::string>{"early", "late"}));
  EXPECT_EQ(names_of(svc.response_fields), (std::vector<std::string>{"code"}));
  EXPECT_EQ(signature(svc), "double 8 1,double 8 1|int32_t 4 1");

  const Definition& ev = library.load("s/ev");
  EXPECT_EQ(ev.kind, Kind::Event);
  EXPECT_EQ(names_of(ev.fields), (std::vector<std::string>{"filter"}));
  EXPECT_EQ(names_of(ev.response_fields), (std::vector<std::string>{"value"}));
  // In a plain definition "request" is just an unknown type.
  EXPECT_NE(library.load_text("s/other", "uint8_t ok\n").name, "");
  EXPECT_NE(load_error(tree, "s/plain_with_markers").find("unknown type 'request'"), std::string::npos);
}

TEST(Parser, PlacesLengthFieldsExactlyAsLn29) {
  DefinitionTree tree;
  tree.write_all({
      {"d/inserted", "service\nrequest\nuint8_t a\nchar* text\n"},
      {"d/after", "service\nrequest\nuint8_t* data\nint data_len\n"},
      {"d/right_before", "service\nrequest\nuint32_t data_len\nuint8_t* data\n"},
      // LN removes the declared length, then inserts it at the pointer's old
      // index: declared two fields early, it lands right after the pointer.
      {"d/two_before", "service\nrequest\nuint32_t data_len\nuint8_t a\nuint8_t* data\n"},
      {"d/plain_dynamic", "uint8_t* bytes\n"},
  });
  Library library(SearchPath::exactly({tree.root()}));

  const Definition& inserted = library.load("d/inserted");
  EXPECT_EQ(names_of(inserted.fields), (std::vector<std::string>{"a", "text_len", "text"}));
  EXPECT_EQ(inserted.fields[1].line, 0);  // implicit
  EXPECT_EQ(signature(inserted), "uint8_t 1 1,uint32_t 4 1,char* 1 1|");

  const Definition& after = library.load("d/after");
  EXPECT_EQ(names_of(after.fields), (std::vector<std::string>{"data_len", "data"}));
  EXPECT_EQ(c_name(*after.fields[0].primitive), "int32_t");

  EXPECT_EQ(names_of(library.load("d/right_before").fields), (std::vector<std::string>{"data_len", "data"}));
  EXPECT_EQ(names_of(library.load("d/two_before").fields), (std::vector<std::string>{"a", "data", "data_len"}));

  const Definition& plain = library.load("d/plain_dynamic");
  EXPECT_TRUE(plain.is_dynamic());
  EXPECT_EQ(names_of(plain.fields), (std::vector<std::string>{"bytes_len", "bytes"}));
  EXPECT_EQ(packet_size(plain), 4u);  // pointed-to data is not part of a packet
}

TEST(Parser, IgnoresCommentsBlanksCarriageReturnsAndTabs) {
  DefinitionTree tree;
  tree.write("c/messy",
             "# header\r\n\r\n  double\tx   # trailing\r\n\tfloat frame [4*4]\r\n#end\r\n"
             "\xc2\xa0int32_t nbsp_around\xe3\x80\x80\n"  // U+00A0 ... U+3000
             "uint8_t tail\xc2\xa0[2]\n");
  Library library(SearchPath::exactly({tree.root()}));
  const Definition& def = library.load("c/messy");
  ASSERT_EQ(names_of(def.fields), (std::vector<std::string>{"x", "frame", "nbsp_around", "tail"}));
  EXPECT_EQ(def.fields[1].count, 16u);
  EXPECT_EQ(def.fields[1].hash_name, "frame ");  // LN keeps the blank before '['
  EXPECT_EQ(def.fields[3].hash_name, "tail\xc2\xa0");
  EXPECT_EQ(def.fields[3].count, 2u);
}

TEST(Parser, ResolvesDefinesNextToTheFileFirstThenOnTheSearchPath) {
  DefinitionTree tree;
  tree.write_all({
      {"a/b/value", "double v\n"},
      {"value", "uint8_t shadowed\n"},
      {"other/point", "float x\nfloat y\n"},
      {"a/b/holder",
       "define value_t as \"value\"\ndefine point as \"other/point\"\n"
       "value_t single\npoint corners[4]\npoint* path\n"},
  });
  Library library(SearchPath::exactly({tree.root()}));
  const Definition& holder = library.load("a/b/holder");
  ASSERT_EQ(holder.defines.size(), 2u);
  EXPECT_EQ(holder.defines[0].absolute_name, "a/b/value");
  EXPECT_EQ(holder.defines[0].definition->fields[0].name, "v");
  EXPECT_EQ(holder.defines[1].absolute_name, "other/point");
  EXPECT_EQ(&library.load("other/point"), holder.defines[1].definition);  // loaded once, shared
  EXPECT_EQ(signature(holder), "[double 8 1] 8 1,[float 4 1,float 4 1] 8 4,uint32_t 4 1,[float 4 1,float 4 1]* 8 1");
}

TEST(Parser, AcceptsADefineRepeatedForTheSameDefinition) {
  DefinitionTree tree;
  tree.write_all({
      {"s/item", "double x\n"},
      {"s/svc",
       "service\nrequest\ndefine item_t as \"item\"\nitem_t a\n"
       "response\ndefine item_t as \"s/item\"\nitem_t b\n"},
      {"s/other", "float y\n"},
      {"s/clash", "define t as \"item\"\nt a\ndefine t as \"other\"\nt b\n"},
  });
  Library library(SearchPath::exactly({tree.root()}));
  const Definition& svc = library.load("s/svc");
  ASSERT_EQ(svc.defines.size(), 1u);
  EXPECT_EQ(svc.fields[0].sub, svc.response_fields[0].sub);
  EXPECT_EQ(signature(svc), "[double 8 1] 8 1|[double 8 1] 8 1");
  // Another target under the same name: LN 2.9 would give both fields the last one.
  const std::string clash = load_error(tree, "s/clash");
  EXPECT_NE(clash.find(":3: type 't' is already defined in line 1 as 's/item'"), std::string::npos) << clash;
}

TEST(Parser, AllowsRecursionOnlyThroughPointers) {
  DefinitionTree tree;
  tree.write_all({
      {"r/node", "define node_t as \"node\"\nint32_t value\nnode_t* children\n"},
      {"r/ping", "define pong_t as \"pong\"\npong_t* other\n"},
      {"r/pong", "define ping_t as \"ping\"\nping_t* other\n"},
      {"r/self_by_value", "define me as \"self_by_value\"\nme inner\n"},
      {"r/a", "define b_t as \"b\"\nb_t inner\n"},
      {"r/b", "define a_t as \"a\"\na_t inner\n"},
  });
  Library library(SearchPath::exactly({tree.root()}));
  const Definition& node = library.load("r/node");
  EXPECT_EQ(node.fields[2].sub, &node);
  EXPECT_EQ(signature(node), "int32_t 4 1,uint32_t 4 1,[]* 0 1");
  // A longer cycle has no unambiguous signature ("[]" names the innermost type).
  const std::string mutual = load_error(tree, "r/ping");
  EXPECT_NE(mutual.find("closes a cycle of types"), std::string::npos) << mutual;

  EXPECT_NE(load_error(tree, "r/self_by_value").find("recursive types must use a pointer"), std::string::npos);
  const std::string cycle = load_error(tree, "r/a");
  EXPECT_NE(cycle.find("contain itself"), std::string::npos) << cycle;
  EXPECT_NE(cycle.find(":2:"), std::string::npos) << cycle;  // file and line of the field
}

struct BadDefinition {
  const char* text;
  const char* expected;  // part of the message
  int line;
};

class ParserErrors : public ::testing::TestWithParam<BadDefinition> {};

TEST_P(ParserErrors, NameFileLineAndCause) {
  DefinitionTree tree;
  const std::string path = tree.write("bad/def", GetParam().text);
  tree.write("bad/svc", "service\nrequest\nint32_t a\n");
  const std::string error = load_error(tree, "bad/def");
  EXPECT_NE(error.find(GetParam().expected), std::string::npos) << error;
  EXPECT_EQ(error.rfind(path + ":" + std::to_string(GetParam().line) + ": ", 0), 0u) << error;
}

INSTANTIATE_TEST_SUITE_P(
    Parser, ParserErrors,
    ::testing::Values(BadDefinition{"double x\nvec3 y\n", "unknown type 'vec3'", 2},
                      BadDefinition{"double x\ndouble** y\n", "only one '*'", 2},
                      BadDefinition{"double x[0]\n", "must be between 1", 1},
                      BadDefinition{"double x[-1]\n", "must be between 1", 1},
                      BadDefinition{"double x[abc]\n", "invalid array count 'abc'", 1},
                      BadDefinition{"double x[2][3]\n", "multi-dimensional", 1},
                      BadDefinition{"double x[3\n", "closing ']'", 1},
                      BadDefinition{"double x\n\nint8_t x\n", "field 'x' is already defined in line 1", 3},
                      BadDefinition{"double my-field\n", "not a valid field name", 1},
                      BadDefinition{"int class\n", "not a valid field name", 1},
                      BadDefinition{"double* x[3]\n", "arrays of dynamic fields", 1},
                      BadDefinition{"doublex\n", "expected 'TYPE NAME'", 1},
                      BadDefinition{"define t as \"missing\"\n", "define refers to 'missing'", 1},
                      BadDefinition{"define t as missing\n", "double quotes", 1},
                      BadDefinition{"define t \"missing\"\n", "expected 'define LOCAL_TYPE as", 1},
                      BadDefinition{"define double as \"svc\"\n", "built-in type", 1},
                      BadDefinition{"define t as \"../up\"\n", "not a valid message-definition name", 1},
                      BadDefinition{"define t as \"svc\"\n", "only plain definitions", 1},
                      BadDefinition{"uint8_t* d\ndouble d_len\n", "must be an integer scalar", 2},
                      BadDefinition{"double ok\ndouble caf\xc3\n", "not valid UTF-8", 2},
                      BadDefinition{"double x[99999*99999*99999]\n", "must be between 1", 1},
                      BadDefinition{"uint8_t a[2147483647]\nuint8_t b[2147483647]\nuint8_t c[2147483647]\n",
                                    "grows beyond 4 GiB at field 'c'", 3}),
    [](const ::testing::TestParamInfo<BadDefinition>& param) { return "case" + std::to_string(param.index); });

TEST(Library, ReportsMissingDefinitionsWithTheSearchedDirectories) {
  DefinitionTree tree;
  Library library(SearchPath::exactly({tree.root()}));
  try {
    library.load("nowhere/to_be_found");
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("'nowhere/to_be_found' not found"), std::string::npos);
    EXPECT_NE(std::string(e.what()).find(tree.root()), std::string::npos);
  }
  EXPECT_THROW(library.load("../etc/passwd"), Error);
}

TEST(Library, KeepsNothingOfAFailedLoad) {
  DefinitionTree tree;
  tree.write_all({
      {"f/outer", "define inner_t as \"inner\"\ninner_t x\n"},
      {"f/inner", "double good\nbroken\n"},
  });
  Library library(SearchPath::exactly({tree.root()}));
  EXPECT_THROW(library.load("f/outer"), Error);
  tree.write("f/inner", "double good\n");
  // The broken inner definition was forgotten, so the fix is picked up.
  EXPECT_EQ(packet_size(library.load("f/outer")), 8u);
}

TEST(Library, LoadsDefinitionsGivenAsText) {
  DefinitionTree tree;
  tree.write("lib/point", "float x\nfloat y\n");
  Library library(SearchPath::exactly({tree.root()}));
  const Definition& def = library.load_text("gen/track", "define p as \"lib/point\"\np points[3]\n");
  EXPECT_EQ(def.path, "<gen/track>");
  EXPECT_EQ(packet_size(def), 24u);
  EXPECT_THROW(library.load_text("gen/track", "double x\n"), Error);
  EXPECT_THROW(library.load_text("gen/bad", "double\n"), Error);
}

TEST(Library, RebuildsDefinitionsFromInMemorySources) {
  DefinitionTree files;
  files.write("a/b/value", "double v\n");
  files.write("other/point", "float x\nfloat y\n");
  files.write("a/b/holder", "define value_t as \"value\"\ndefine p as \"other/point\"\nvalue_t v\np pts[2]\n");
  Library from_files(SearchPath::exactly({files.root()}));
  const Definition& original = from_files.load("a/b/holder");

  // What a manager sends: the definition and everything it imports.
  Library from_texts(SearchPath::exactly({}));
  from_texts.add_source("a/b/holder",
                        "define value_t as \"value\"\ndefine p as \"other/point\"\nvalue_t v\np pts[2]\n");
  from_texts.add_source("a/b/value", "double v\n");
  from_texts.add_source("other/point", "float x\nfloat y\n");
  const Definition& rebuilt = from_texts.load("a/b/holder");
  EXPECT_EQ(rebuilt.hash, original.hash);
  EXPECT_EQ(signature(rebuilt), signature(original));
  EXPECT_EQ(rebuilt.defines[0].absolute_name, "a/b/value");
  EXPECT_EQ(rebuilt.defines[1].absolute_name, "other/point");
  EXPECT_THROW(from_texts.add_source("a/b/value", "double changed\n"), Error);
  EXPECT_NO_THROW(from_texts.add_source("a/b/value", "double v\n"));
}

}  // namespace
}  // namespace ln::md
