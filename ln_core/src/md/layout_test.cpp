#include <gtest/gtest.h>

#include "ln/md/message_definition.hpp"
#include "md/test_support.hpp"

namespace ln::md {
namespace {

using testing::DefinitionTree;

TEST(Layout, PackedHostStructsCountPointersAndNestedStructs) {
  DefinitionTree tree;
  tree.write("l/blob", "uint8_t* data\nint32_t is_pickle\n");  // host: 4 + 8 + 4
  tree.write("l/req",
             "service\nrequest\ndefine blob as \"blob\"\nuint64_t count\nint16_t s[4]\n"
             "blob single\nblob pair[2]\nblob* many\nresponse\ndouble t\n");
  Library library(SearchPath::exactly({tree.root()}));
  const Definition& req = library.load("l/req");
  const StructLayout request = struct_layout(req.fields);
  EXPECT_EQ(request.offsets, (std::vector<std::size_t>{0, 8, 16, 32, 64, 68}));
  EXPECT_EQ(request.size, 76u);
  EXPECT_EQ(struct_layout(req.fields, 4).size, 76u - 3 * 4 - 4);  // a 32-bit host
  // In a signature a sub-type's size counts only its non-pointer fields.
  EXPECT_EQ(signature(req),
            "uint64_t 8 1,int16_t 2 4,[uint32_t 4 1,uint8_t* 1 1,int32_t 4 1] 8 1,"
            "[uint32_t 4 1,uint8_t* 1 1,int32_t 4 1] 8 2,uint32_t 4 1,"
            "[uint32_t 4 1,uint8_t* 1 1,int32_t 4 1]* 8 1|double 8 1");
}

TEST(Layout, LocatesMembersLikeLn) {
  DefinitionTree tree;
  tree.write_all({
      {"m/vec", "double xyz[3]\n"},
      {"m/pose", "define vec as \"vec\"\nuint32_t id\nvec position\nvec axes[3]\nfloat q[4]\n"},
  });
  Library library(SearchPath::exactly({tree.root()}));
  const Definition& pose = library.load("m/pose");
  EXPECT_EQ(packet_size(pose), 4u + 24 + 72 + 16);
  auto at = [&](const char* member) { return locate_member(pose, member); };
  EXPECT_EQ(at("id").offset, 0u);
  EXPECT_EQ(at("id").size, 4u);
  EXPECT_EQ(at("position").offset, 4u);
  EXPECT_EQ(at("position").size, 24u);
  EXPECT_EQ(at("position.xyz[2]").offset, 4u + 16);
  EXPECT_EQ(at("position.xyz[2]").size, 8u);
  EXPECT_EQ(at("axes[1].xyz[0]").offset, 4u + 24 + 24);
  EXPECT_EQ(at("q[-1]").offset, 4u + 24 + 72 + 12);  // Python-style index from the end
  EXPECT_THROW(at("q[4]"), Error);
  EXPECT_THROW(at("nothing"), Error);
  EXPECT_THROW(at("id.sub"), Error);
  EXPECT_THROW(at("q[x]"), Error);
}

}  // namespace
}  // namespace ln::md
