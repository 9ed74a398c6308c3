#include "services/signature.hpp"

#include <gtest/gtest.h>

#include <string>

#define NO_CPP_WRAPPER
#include "ln/ln.h"

namespace ln::services {
namespace {

constexpr std::size_t ptr = sizeof(void*);

MessageLayout compiled(const std::string& side, bool swap = false) {
  MessageLayout layout;
  const Status s = MessageLayout::compile(side, layout, swap);
  EXPECT_TRUE(s.ok()) << side << ": " << s.detail();
  return layout;
}

int compile_error(const std::string& side) {
  MessageLayout layout;
  return MessageLayout::compile(side, layout, false).code();
}

TEST(Signature, LN29TimeServiceLayout) {
  // The signature LN 2.9's ln_generate writes for tests/time_service.
  const char* sig =
      "uint64_t 8 1,int16_t 2 1,int16_t 2 4,uint32_t 4 1,int16_t* 2 1,[int32_t 4 1,uint8_t* 1 1,int32_t 4 1] 8 1,"
      "[int32_t 4 1,uint8_t* 1 1,int32_t 4 1] 8 2,uint32_t 4 1,[int32_t 4 1,uint8_t* 1 1,int32_t 4 1]* 8 1"
      "|double 8 1,uint64_t 8 1";
  ServiceSignature s;
  ASSERT_TRUE(ServiceSignature::compile(sig, s).ok());
  const std::size_t pyobject = 4 + ptr + 4;
  EXPECT_EQ(s.request().host_size(), 8 + 2 + 8 + 4 + ptr + pyobject + 2 * pyobject + 4 + ptr);
  EXPECT_EQ(s.response().host_size(), 16u);
  EXPECT_EQ(s.response_offset(), s.request().host_size());
  EXPECT_FALSE(s.request().fixed_size());
  EXPECT_TRUE(s.response().fixed_size());
  EXPECT_EQ(s.text(), sig);
}

TEST(Signature, CountCompanionBeforePointerInItsOwnType) {
  const MessageLayout layout = compiled("int32_t 4 1,uint8_t* 1 1,int32_t 4 1");
  ASSERT_EQ(layout.programs().size(), 1u);
  const auto& steps = layout.programs()[0].steps;
  ASSERT_EQ(steps.size(), 2u);
  EXPECT_EQ(steps[0].kind, Step::Kind::Dynamic);
  EXPECT_EQ(steps[0].count_offset, 0u);
  EXPECT_EQ(steps[0].host_offset, 4u);
  EXPECT_EQ(steps[0].count_type, md::Primitive::Int32);
  EXPECT_EQ(steps[1].kind, Step::Kind::Copy);  // is_pickle
  EXPECT_EQ(steps[1].host_offset, 4 + ptr);
}

TEST(Signature, CountCompanionAfterPointerWhenNoneBefore) {
  const MessageLayout layout = compiled("double* 8 1,uint16_t 2 1");
  const auto& steps = layout.programs()[0].steps;
  ASSERT_EQ(steps.size(), 1u);
  EXPECT_EQ(steps[0].host_offset, 0u);
  EXPECT_EQ(steps[0].count_offset, ptr);
  EXPECT_EQ(steps[0].count_type, md::Primitive::UInt16);
  EXPECT_EQ(layout.host_size(), ptr + 2);
}

TEST(Signature, BeforeWinsOverAfterAndCompanionsServeOnePointer) {
  // LN's rule: the length before the pointer. The uint32 between the two
  // pointers belongs to the second, so the first has none.
  EXPECT_EQ(compile_error("char* 1 1,uint32_t 4 1,char* 1 1"), -LNE_INVALID_SIGNATURE);
  const MessageLayout layout = compiled("uint32_t 4 1,char* 1 1,char* 1 1,uint32_t 4 1");
  const auto& steps = layout.programs()[0].steps;
  ASSERT_EQ(steps.size(), 2u);
  EXPECT_EQ(steps[0].count_offset, 0u);
  EXPECT_EQ(steps[1].count_offset, 4 + 2 * ptr);
}

TEST(Signature, AdjacentFixedFieldsMergeIntoOneCopy) {
  const MessageLayout little = compiled("int32_t 4 1,double 8 2,uint8_t 1 3,[double 8 1,float 4 1] 12 2");
  ASSERT_EQ(little.programs()[0].steps.size(), 1u);
  EXPECT_EQ(little.programs()[0].steps[0].size, 4 + 16 + 3 + 24u);
  EXPECT_TRUE(little.fixed_size());

  // Converting byte order, only runs of one element size merge.
  const MessageLayout swapped = compiled("int32_t 4 1,int32_t 4 2,double 8 1", true);
  ASSERT_EQ(swapped.programs()[0].steps.size(), 2u);
  EXPECT_EQ(swapped.programs()[0].steps[0].size, 12u);
  EXPECT_EQ(swapped.programs()[0].steps[0].swap_unit, 4u);
  EXPECT_EQ(swapped.programs()[0].steps[1].swap_unit, 8u);
}

TEST(Signature, RecursionRefersToTheInnermostEnclosingType) {
  // svc_test/node used by value in a request: "[]" is the node itself.
  const MessageLayout layout = compiled("double 8 1,[int32_t 4 1,uint32_t 4 1,[]* 0 1] 8 1");
  ASSERT_EQ(layout.programs().size(), 2u);
  const StructProgram& node = layout.programs()[1];
  EXPECT_EQ(node.host_size, 8 + ptr);
  ASSERT_EQ(node.steps.size(), 2u);
  EXPECT_EQ(node.steps[1].kind, Step::Kind::Dynamic);
  EXPECT_EQ(node.steps[1].program, 1);
  EXPECT_EQ(layout.programs()[0].steps[1].kind, Step::Kind::Structs);

  // At top level "[]" is the side itself (a plain recursive definition).
  const MessageLayout top = compiled("int32_t 4 1,uint32_t 4 1,[]* 0 1");
  EXPECT_EQ(top.programs()[0].steps[1].program, 0);
}

TEST(Signature, EmptySides) {
  ServiceSignature s;
  ASSERT_TRUE(ServiceSignature::compile("|", s).ok());
  EXPECT_TRUE(s.request().empty());
  EXPECT_TRUE(s.response().empty());
  ASSERT_TRUE(ServiceSignature::compile("|double 8 1", s).ok());
  EXPECT_TRUE(s.request().empty());
  EXPECT_EQ(s.response().host_size(), 8u);
  EXPECT_EQ(s.response_offset(), 0u);
  ASSERT_TRUE(ServiceSignature::compile("int32_t 4 1|", s).ok());
  EXPECT_TRUE(s.response().empty());
}

TEST(Signature, ToleratesExtraBlanks) { EXPECT_EQ(compiled(" int32_t  4  1 , double 8 1 ").host_size(), 12u); }

TEST(Signature, RejectsMalformedSignatures) {
  for (const char* bad : {
           "int32_t 4",                                  // count missing
           "int32_t4 1",                                 // blank missing
           "int32 4 1",                                  // unknown type
           "int32_t 8 1",                                // wrong element size
           "int32_t 4 0",                                // count 0
           "int32_t* 4 2",                               // array of pointers
           "char* 1 1",                                  // no length field
           "uint32_t 4 2,char* 1 1",                     // an array is no length
           "char 1 1,char* 1 1",                         // neither is char
           "float 4 1,char* 1 1",                        // nor a float
           "[]* 0 1",                                    // recursion needs ... a length here
           "uint32_t 4 1,[] 0 1",                        // recursion by value: infinite
           "[int32_t 4 1 8 1",                           // unbalanced
           "int32_t 4 1]",                               // stray bracket
           "[ ] 0 1",                                    // empty sub-type
           "int32_t 4 1,",                               // empty entry
           "int32_t 4 1 x",                              // trailing garbage
           "int32_t 4 99999999999999999",                // absurd number
           "uint8_t 1 2147483647,uint8_t 1 2147483647",  // struct beyond 2 GiB
       }) {
    EXPECT_EQ(compile_error(bad), -LNE_INVALID_SIGNATURE) << bad;
  }
  std::string deep;
  for (int i = 0; i < 100; ++i) deep += "[";
  deep += "int32_t 4 1";
  for (int i = 0; i < 100; ++i) deep += "] 4 1";
  EXPECT_EQ(compile_error(deep), -LNE_INVALID_SIGNATURE);

  ServiceSignature s;
  EXPECT_EQ(ServiceSignature::compile("int32_t 4 1", s).code(), -LNE_INVALID_SIGNATURE);
  EXPECT_EQ(ServiceSignature::compile("|int32_t 4 1|", s).code(), -LNE_INVALID_SIGNATURE);
  const Status error = ServiceSignature::compile("int32_t 4 1|char* 1 1", s);
  EXPECT_NE(error.detail().find("no integer length"), std::string::npos) << error.detail();
}

TEST(Signature, SetDataComparesPlainStrings) {
  EXPECT_TRUE(same_signature("int32_t 4 1|", "int32_t 4 1|"));
  EXPECT_FALSE(same_signature("int32_t 4 1|", "int32_t  4 1|"));
  EXPECT_FALSE(same_signature("int32_t 4 1|", nullptr));
}

}  // namespace
}  // namespace ln::services
