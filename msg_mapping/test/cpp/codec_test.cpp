#include <gtest/gtest.h>

#include <cstring>

#include "msg_mapping/codec.hpp"
#include "test_support.hpp"

namespace msg_mapping {
namespace {

using test::bytes_of;
using test::hex;

// LN -> CDR gives `cdr`, and CDR -> LN gives `flat` back.
void expect_both_ways(const Codec& codec, const std::vector<std::uint8_t>& flat, const std::vector<std::uint8_t>& cdr) {
  EXPECT_EQ(codec.ln_to_cdr(bytes_of(flat)), cdr);
  EXPECT_EQ(codec.cdr_to_ln(bytes_of(cdr)), flat);
}

std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const CodecError& e) {
    return e.what();
  }
  return "(no error)";
}

TEST(Codec, WorkedExampleFromTheWireNotes) {
  test::LnFixture ln({{"t/worked", "uint8_t a\ndouble b\nchar* s\n"}});
  const Codec codec = ln.codec("t/worked");
  const auto flat = hex("05 | 000000000000f03f | 02000000 6869");
  const auto cdr = hex("00010000 | 05 | 00000000000000 | 000000000000f03f | 03000000 | 686900");
  expect_both_ways(codec, flat, cdr);
  EXPECT_EQ(codec.cdr_size(bytes_of(flat)), 27u);
  EXPECT_EQ(codec.ln_size(bytes_of(cdr)), flat.size());
}

TEST(Codec, FixedArraysAreOneCopy) {
  test::LnFixture ln({{"t/array", "double data[8]\n"},
                      {"t/point", "double x\ndouble y\ndouble z\n"},
                      {"t/corners", "define p as \"t/point\"\nuint32_t n\np corners[4]\nfloat f[3]\n"}});
  const Codec codec = ln.codec("t/array");
  EXPECT_EQ(codec.fixed_ln_size(), 64u);
  EXPECT_EQ(codec.fixed_cdr_size(), 68u);
  EXPECT_NE(codec.describe().find("copy data size=64 pad=0"), std::string::npos) << codec.describe();
  std::vector<std::uint8_t> flat(64);
  for (std::size_t i = 0; i < flat.size(); ++i) flat[i] = static_cast<std::uint8_t>(i);
  const auto cdr = codec.ln_to_cdr(bytes_of(flat));
  EXPECT_EQ(std::vector<std::uint8_t>(cdr.begin() + 4, cdr.end()), flat);

  // uint32 n; (pad 4) 4 dense points and 3 floats in one block: two memcpys, no loop
  const Codec corners = ln.codec("t/corners");
  EXPECT_EQ(corners.describe(),
            "routine 0 t_ln_msgs/msg/Corners fixed ln=112\n"
            "  copy n size=4 pad=0\n"
            "  copy corners..f size=108 pad=4\n")
      << corners.describe();
}

TEST(Codec, PlainTypesEndPaddedLikeRmwFastrtps) {
  test::LnFixture ln({{"t/byte", "uint8_t x\n"}, {"t/empty", ""}});
  const Codec codec = ln.codec("t/byte");
  const std::vector<std::uint8_t> flat{5};
  EXPECT_EQ(codec.ln_to_cdr(bytes_of(flat)), hex("00010000 05 000000"));
  const Codec empty = ln.codec("t/empty");
  EXPECT_EQ(empty.ln_to_cdr(Bytes{}), hex("00010000 00 000000"));  // rosidl's dummy member
  EXPECT_TRUE(empty.cdr_to_ln(bytes_of(hex("00010000 00 000000"))).empty());
}

TEST(Codec, EmptyNumberSequencesAreNotAlignedButCounted) {
  test::LnFixture ln({{"t/seq", "double* v\nuint8_t c\n"}});
  const Codec codec = ln.codec("t/seq");
  const auto flat = hex("00000000 07");
  // Fast CDR writes no alignment for the empty double block; its size estimate does (trailing zeros).
  expect_both_ways(codec, flat, hex("00010000 00000000 07 00000000"));
  const auto one = hex("01000000 000000000000f03f 07");
  EXPECT_EQ(codec.ln_to_cdr(bytes_of(one)), hex("00010000 01000000 00000000 000000000000f03f 07"));
}

TEST(Codec, RecursiveTypesTravelAsLnFlatBytes) {
  test::LnFixture ln({{"t/tree", "uint16_t w\ndefine t as \"t/tree\"\nt* kids\n"}});
  const PairedInterface& i = ln.add("t/tree");
  EXPECT_EQ(i.first->fields[1].shape, Shape::Opaque);
  const Codec codec(*i.first);
  // w=1, kids=[{w=2, kids=[]}]
  const auto flat = hex("0100 01000000 0200 00000000");
  expect_both_ways(codec, flat, hex("00010000 0100 0000 0a000000 01000000 0200 00000000"));
  // leaf: empty kids -> empty uint8[]
  EXPECT_EQ(codec.ln_to_cdr(bytes_of(hex("0900 00000000"))), hex("00010000 0900 0000 00000000"));
  // opaque bytes that are not one LN sequence are rejected
  EXPECT_NE(error_of([&] {
              codec.cdr_to_ln(bytes_of(hex("00010000 0100 0000 05000000 01000000 02")));
            }).find("LN flat bytes"),
            std::string::npos);
  EXPECT_NE(error_of([&] {
              codec.cdr_to_ln(bytes_of(hex("00010000 0100 0000 0b000000 01000000 0200 00000000 ff")));
            }).find("after the sequence"),
            std::string::npos);
}

TEST(Codec, BadInputGivesClearErrors) {
  test::LnFixture ln({{"t/worked", "uint8_t a\ndouble b\nchar* s\n"},
                      {"t/seq", "define p as \"t/pair\"\np* items\n"},
                      {"t/pair", "uint8_t a\nchar* s\n"},
                      {"t/fixed", "double x\n"}});
  const Codec worked = ln.codec("t/worked");
  EXPECT_NE(error_of([&] {
              worked.ln_to_cdr(bytes_of(hex("05 000000000000f03f 05000000 6869")));
            }).find("t_ln_msgs/msg/Worked: s: input truncated"),
            std::string::npos);
  EXPECT_NE(
      error_of([&] { worked.ln_to_cdr(bytes_of(hex("05 000000000000f03f 00000000 ff"))); }).find("1 byte(s) left over"),
      std::string::npos);
  EXPECT_NE(error_of([&] {
              worked.cdr_to_ln(bytes_of(hex("00010000 05 00000000000000 000000000000f03f 03000000 686969")));
            }).find("not NUL-terminated"),
            std::string::npos);
  EXPECT_NE(error_of([&] { worked.cdr_to_ln(bytes_of(hex("0000 0000 05"))); }).find("big-endian"), std::string::npos);
  EXPECT_NE(error_of([&] { worked.cdr_to_ln(bytes_of(hex("0001"))); }).find("header"), std::string::npos);
  const Codec seq = ln.codec("t/seq");
  EXPECT_NE(error_of([&] {
              seq.cdr_to_ln(bytes_of(hex("00010000 ffffffff 00")));
            }).find("items: sequence count 4294967295 is impossible"),
            std::string::npos);
  EXPECT_NE(error_of([&] { seq.ln_to_cdr(bytes_of(hex("ffffff7f 00"))); }).find("impossible"), std::string::npos);
  EXPECT_NE(error_of([&] {
              seq.cdr_to_ln(bytes_of(hex("00010000 02000000 01 000000 02000000 6100 02 000000 ff000000")));
            }).find("items: [1]: s: input truncated"),
            std::string::npos);
  const Codec fixed = ln.codec("t/fixed");
  EXPECT_NE(error_of([&] { fixed.ln_to_cdr(bytes_of(hex("0102"))); }).find("expected 8"), std::string::npos);
  std::vector<std::uint8_t> small(10);
  const auto flat = hex("0000000000000000");
  EXPECT_NE(error_of([&] {
              fixed.ln_to_cdr(bytes_of(flat), {small.data(), small.size()});
            }).find("output buffer too small"),
            std::string::npos);
}

}  // namespace
}  // namespace msg_mapping
