#include "services/marshal.hpp"

#include <gtest/gtest.h>

#include <cstring>
#include <random>
#include <string>
#include <vector>

#define NO_CPP_WRAPPER
#include "ln/ln.h"

namespace ln::services {
namespace {

// Host structs as ln_generate lays them out for the signatures below.
#pragma pack(push, 1)
struct Simple {  // int32_t a, char* s
  int32_t a;
  uint32_t s_len;
  char* s;
};
struct PyObject {  // ln2/pyobject: its int length sits before the pointer
  int32_t data_len;
  uint8_t* data;
  int32_t is_pickle;
};
struct LenAfter {  // a hand-written signature with the length behind
  double* values;
  uint16_t values_len;
};
struct SmallLen {
  uint8_t n;
  int16_t* v;
};
struct Node {
  int32_t value;
  uint32_t children_len;
  Node* children;
};
struct Big {
  uint32_t bytes_len;
  uint8_t* bytes;
  uint32_t doubles_len;
  double* doubles;
};
struct Named {
  uint32_t name_len;
  char* name;
  int32_t id;
  uint32_t tags_len;
  uint16_t* tags;
};
struct Nested {
  double x;
  Named single;
  Named pair[2];
  uint32_t items_len;
  Named* items;
  float tail[3];
};
#pragma pack(pop)

const char* const simple_sig = "int32_t 4 1,uint32_t 4 1,char* 1 1";
const char* const pyobject_sig = "int32_t 4 1,uint8_t* 1 1,int32_t 4 1";
const char* const len_after_sig = "double* 8 1,uint16_t 2 1";
const char* const small_len_sig = "uint8_t 1 1,int16_t* 2 1";
const char* const node_sig = "int32_t 4 1,uint32_t 4 1,[]* 0 1";
const char* const big_sig = "uint32_t 4 1,uint8_t* 1 1,uint32_t 4 1,double* 8 1";
#define NAMED "[uint32_t 4 1,char* 1 1,int32_t 4 1,uint32_t 4 1,uint16_t* 2 1]"
const char* const nested_sig = "double 8 1," NAMED " 12 1," NAMED " 12 2,uint32_t 4 1," NAMED "* 12 1,float 4 3";

MessageLayout layout_of(const char* sig, bool swap = false) {
  MessageLayout layout;
  const Status s = MessageLayout::compile(sig, layout, swap);
  EXPECT_TRUE(s.ok()) << s.detail();
  return layout;
}

template <class T>
std::string flat_of(const MessageLayout& layout, const T& host, const Limits& limits = {}) {
  std::string out;
  const Status s = flatten(layout, &host, limits, out);
  EXPECT_TRUE(s.ok()) << s.detail();
  return out;
}

std::string bytes(std::initializer_list<int> values) {
  std::string out;
  for (int v : values) out.push_back(static_cast<char>(v));
  return out;
}

// ------------------------------------------------------------ fixtures data

struct NestedData {
  char names[4][8] = {"single", "first", "second", "item"};
  uint16_t tags[4][3] = {{1, 2, 3}, {4, 5, 6}, {7, 8, 9}, {10, 11, 12}};
  Named items[2];
  Nested value{};

  static Named named(char* name, uint32_t name_len, int32_t id, uint16_t* tags, uint32_t tags_len) {
    Named n{};
    n.name_len = name_len;
    n.name = name;
    n.id = id;
    n.tags_len = tags_len;
    n.tags = tags;
    return n;
  }

  NestedData() {
    value.x = 3.25;
    value.single = named(names[0], 6, -1, tags[0], 3);
    value.pair[0] = named(names[1], 5, 10, tags[1], 2);
    value.pair[1] = named(names[2], 6, 11, nullptr, 0);
    items[0] = named(names[3], 4, 20, tags[3], 3);
    items[1] = named(nullptr, 0, 21, tags[2], 1);
    value.items_len = 2;
    value.items = items;
    value.tail[0] = 1.5f;
    value.tail[1] = -2.5f;
    value.tail[2] = 1e30f;
  }
};

void expect_same(const Named& a, const Named& b) {
  ASSERT_EQ(a.name_len, b.name_len);
  EXPECT_EQ(std::string(a.name, a.name_len), std::string(b.name, b.name_len));
  EXPECT_EQ(a.id, b.id);
  ASSERT_EQ(a.tags_len, b.tags_len);
  for (uint32_t i = 0; i < a.tags_len; ++i) EXPECT_EQ(a.tags[i], b.tags[i]);
}

void expect_same(const Nested& a, const Nested& b) {
  EXPECT_EQ(a.x, b.x);
  expect_same(a.single, b.single);
  expect_same(a.pair[0], b.pair[0]);
  expect_same(a.pair[1], b.pair[1]);
  ASSERT_EQ(a.items_len, b.items_len);
  for (uint32_t i = 0; i < a.items_len; ++i) expect_same(a.items[i], b.items[i]);
  for (int i = 0; i < 3; ++i) EXPECT_EQ(a.tail[i], b.tail[i]);
}

// ------------------------------------------------------------------- tests

TEST(Marshal, DocumentedExample) {
  char abc[] = "abc";
  const Simple host{1, 3, abc};
  const MessageLayout layout = layout_of(simple_sig);
  EXPECT_EQ(flat_of(layout, host), bytes({1, 0, 0, 0, 3, 0, 0, 0, 'a', 'b', 'c'}));
}

TEST(Marshal, WireIsLittleEndianWhateverTheHost) {
  // Compiled as a big-endian host would be, multi-byte fields are reversed
  // on the way out (here: a little-endian host pretending), and restored on
  // the way in.
  const MessageLayout swapped = layout_of("int32_t 4 1,uint16_t 2 1,double 8 1,uint32_t 4 1,int16_t* 2 1", true);
#pragma pack(push, 1)
  struct Host {
    int32_t a;
    uint16_t b;
    double c;
    uint32_t v_len;
    int16_t* v;
  };
#pragma pack(pop)
  int16_t v[2] = {0x0102, 0x0304};
  Host host{0x01020304, 0x0506, 1.0, 2, v};
  const std::string wire = flat_of(swapped, host);
  std::string expected = bytes({1, 2, 3, 4, 5, 6});
  double one = 1.0;
  std::string one_bytes(reinterpret_cast<const char*>(&one), 8);
  expected += std::string(one_bytes.rbegin(), one_bytes.rend());
  expected += bytes({2, 0, 0, 0, 1, 2, 3, 4});  // the count is always little endian
  EXPECT_EQ(wire, expected);

  std::string received = wire;
  Host back{};
  Arena arena;
  ASSERT_TRUE(unflatten(swapped, received.data(), received.size(), &back, {}, arena).ok());
  // (Unary + reads packed members by value: gtest binds references.)
  EXPECT_EQ(+back.a, +host.a);
  EXPECT_EQ(+back.b, +host.b);
  EXPECT_EQ(+back.c, +host.c);
  ASSERT_EQ(+back.v_len, 2u);
  EXPECT_EQ(back.v[0], 0x0102);
  EXPECT_EQ(back.v[1], 0x0304);
}

TEST(Marshal, NestedRoundTripInBothByteOrders) {
  for (bool swap : {false, true}) {
    SCOPED_TRACE(swap ? "swapped" : "native");
    NestedData data;
    const MessageLayout layout = layout_of(nested_sig, swap);
    ASSERT_EQ(layout.host_size(), sizeof(Nested));
    std::string wire = flat_of(layout, data.value);
    Nested back{};
    Arena arena;
    const Status s = unflatten(layout, wire.data(), wire.size(), &back, {}, arena);
    ASSERT_TRUE(s.ok()) << s.detail();
    expect_same(data.value, back);
    // And the unflattened struct flattens to the same bytes again.
    EXPECT_EQ(flat_of(layout, back), wire);
  }
}

TEST(Marshal, LengthFieldsOfOtherTypesAndPositions) {
  uint8_t payload[] = {9, 8, 7};
  const PyObject py{3, payload, 1};
  const MessageLayout py_layout = layout_of(pyobject_sig);
  std::string wire = flat_of(py_layout, py);
  EXPECT_EQ(wire, bytes({3, 0, 0, 0, 9, 8, 7, 1, 0, 0, 0}));
  PyObject py_back{};
  Arena arena;
  ASSERT_TRUE(unflatten(py_layout, wire.data(), wire.size(), &py_back, {}, arena).ok());
  EXPECT_EQ(py_back.data_len, 3);
  EXPECT_EQ(py_back.data[2], 7);
  EXPECT_EQ(py_back.is_pickle, 1);

  double values[] = {1.5, 2.5};
  const LenAfter after{values, 2};
  const MessageLayout after_layout = layout_of(len_after_sig);
  wire = flat_of(after_layout, after);
  LenAfter after_back{};
  ASSERT_TRUE(unflatten(after_layout, wire.data(), wire.size(), &after_back, {}, arena).ok());
  ASSERT_EQ(after_back.values_len, 2u);
  EXPECT_EQ(after_back.values[1], 2.5);
}

TEST(Marshal, RejectsBadHostData) {
  const MessageLayout py_layout = layout_of(pyobject_sig);
  std::string out;
  uint8_t one = 1;
  const PyObject negative{-1, &one, 0};
  EXPECT_EQ(flatten(py_layout, &negative, {}, out).code(), -LNE_INVALID_PARAMETER);
  const PyObject null_with_length{2, nullptr, 0};
  const Status s = flatten(py_layout, &null_with_length, {}, out);
  EXPECT_EQ(s.code(), -LNE_INVALID_PARAMETER);
  EXPECT_NE(s.detail().find("NULL"), std::string::npos) << s.detail();

  const PyObject null_empty{0, nullptr, 0};
  ASSERT_TRUE(flatten(py_layout, &null_empty, {}, out).ok());
  PyObject back{};
  Arena arena;
  ASSERT_TRUE(unflatten(py_layout, out.data(), out.size(), &back, {}, arena).ok());
  EXPECT_EQ(back.data_len, 0);
  const uint8_t* empty_array = back.data;
  EXPECT_NE(empty_array, nullptr);  // an empty array still points somewhere valid

  Node cycle{1, 1, nullptr};
  cycle.children = &cycle;
  EXPECT_EQ(flatten(layout_of(node_sig), &cycle, {}, out).code(), -LNE_INVALID_PARAMETER);
}

TEST(Marshal, CountsMustFitTheirLengthField) {
  const MessageLayout layout = layout_of(small_len_sig);
  std::string wire = bytes({0x2c, 0x01, 0, 0});  // 300 elements for a uint8_t length
  wire.append(600, '\0');
  SmallLen back{};
  Arena arena;
  const Status s = unflatten(layout, wire.data(), wire.size(), &back, {}, arena);
  EXPECT_EQ(s.code(), -LNE_INVALID_PARAMETER);
  EXPECT_EQ(back.n, 0);  // untouched on failure
}

TEST(Marshal, RecursiveTree) {
  Node leaves[3] = {{3, 0, nullptr}, {4, 0, nullptr}, {5, 0, nullptr}};
  Node middle[2] = {{1, 2, leaves}, {2, 1, leaves + 2}};
  const Node root{0, 2, middle};
  const MessageLayout layout = layout_of(node_sig);
  std::string wire = flat_of(layout, root);
  Node back{};
  Arena arena;
  ASSERT_TRUE(unflatten(layout, wire.data(), wire.size(), &back, {}, arena).ok());
  ASSERT_EQ(back.children_len, 2u);
  ASSERT_EQ(back.children[0].children_len, 2u);
  EXPECT_EQ(back.children[0].children[1].value, 4);
  EXPECT_EQ(back.children[1].children[0].value, 5);
  EXPECT_EQ(back.children[1].children[0].children_len, 0u);
}

TEST(Marshal, NestingLimitBoundsRecursionBothWays) {
  std::vector<Node> chain(200);
  for (std::size_t i = 0; i < chain.size(); ++i)
    chain[i] = {static_cast<int32_t>(i), i + 1 < chain.size() ? 1u : 0u,
                i + 1 < chain.size() ? &chain[i + 1] : nullptr};
  const MessageLayout layout = layout_of(node_sig);
  std::string wire;
  EXPECT_EQ(flatten(layout, chain.data(), {}, wire).code(), -LNE_INVALID_PARAMETER);
  Limits deep;
  deep.max_nesting = 300;
  ASSERT_TRUE(flatten(layout, chain.data(), deep, wire).ok());
  Node back{};
  Arena arena;
  EXPECT_EQ(unflatten(layout, wire.data(), wire.size(), &back, {}, arena).code(), -LNE_INVALID_PARAMETER);
  ASSERT_TRUE(unflatten(layout, wire.data(), wire.size(), &back, deep, arena).ok());
  EXPECT_EQ(back.children[0].children[0].value, 2);
}

TEST(Marshal, SixteenMegabytePayloadsAreUsedInPlaceWhenAligned) {
  std::vector<uint8_t> blob(16u << 20);
  std::vector<double> doubles(2u << 20);
  for (std::size_t i = 0; i < blob.size(); ++i) blob[i] = static_cast<uint8_t>(i * 7);
  for (std::size_t i = 0; i < doubles.size(); ++i) doubles[i] = static_cast<double>(i) * 0.5;
  const Big host{static_cast<uint32_t>(blob.size()), blob.data(), static_cast<uint32_t>(doubles.size()),
                 doubles.data()};
  const MessageLayout layout = layout_of(big_sig);
  std::string wire = flat_of(layout, host);
  ASSERT_EQ(wire.size(), 8 + blob.size() + 8 * doubles.size());

  Big back{};
  Arena arena;
  ASSERT_TRUE(unflatten(layout, wire.data(), wire.size(), &back, {}, arena).ok());
  ASSERT_EQ(back.bytes_len, blob.size());
  EXPECT_EQ(std::memcmp(back.bytes, blob.data(), blob.size()), 0);
  ASSERT_EQ(back.doubles_len, doubles.size());
  EXPECT_EQ(std::memcmp(back.doubles, doubles.data(), 8 * doubles.size()), 0);
  const char* begin = wire.data();
  const char* end = begin + wire.size();
  const auto inside = [&](const void* p) {
    return p >= static_cast<const void*>(begin) && p < static_cast<const void*>(end);
  };
  EXPECT_TRUE(inside(back.bytes));
  EXPECT_TRUE(inside(back.doubles));  // wire.data() is 8-aligned, so are the doubles

  // Shifted by one byte the doubles are misaligned: they get copied.
  std::string shifted = " " + wire;
  Big copy{};
  ASSERT_TRUE(unflatten(layout, shifted.data() + 1, wire.size(), &copy, {}, arena).ok());
  EXPECT_FALSE(shifted.data() <= reinterpret_cast<char*>(copy.doubles) &&
               reinterpret_cast<char*>(copy.doubles) < shifted.data() + shifted.size());
  EXPECT_EQ(std::memcmp(copy.doubles, doubles.data(), 8 * doubles.size()), 0);
}

TEST(Marshal, SizeLimit) {
  std::vector<uint8_t> blob(2000);
  const Big host{static_cast<uint32_t>(blob.size()), blob.data(), 0, nullptr};
  Limits small;
  small.max_data_size = 1000;
  std::string wire;
  EXPECT_EQ(flatten(layout_of(big_sig), &host, small, wire).code(), -LNE_PACKET_TOO_LARGE);
  Limits fixed_small;
  fixed_small.max_data_size = 4;
  const double d = 1;
  EXPECT_EQ(flatten(layout_of("double 8 1"), &d, fixed_small, wire).code(), -LNE_PACKET_TOO_LARGE);
}

TEST(Marshal, EmptySideAndTrailingBytes) {
  MessageLayout empty;
  ASSERT_TRUE(MessageLayout::compile("", empty).ok());
  std::string wire = "x";
  Arena arena;
  EXPECT_TRUE(flatten(empty, nullptr, {}, wire).ok());
  EXPECT_TRUE(wire.empty());
  EXPECT_TRUE(unflatten(empty, wire.data(), 0, nullptr, {}, arena).ok());
  char junk = 0;
  EXPECT_FALSE(unflatten(empty, &junk, 1, nullptr, {}, arena).ok());

  char abc[] = "abc";
  const Simple host{1, 3, abc};
  const MessageLayout layout = layout_of(simple_sig);
  wire = flat_of(layout, host) + "!";
  Simple back{};
  EXPECT_EQ(unflatten(layout, wire.data(), wire.size(), &back, {}, arena).code(), -LNE_INVALID_PARAMETER);
}

// Whatever the bytes, unflatten either fails cleanly or yields a struct
// that flattens back to exactly those bytes (run under ASan/UBSan too).
TEST(Marshal, FuzzedAndTruncatedInput) {
  NestedData data;
  const MessageLayout layout = layout_of(nested_sig);
  const std::string valid = flat_of(layout, data.value);
  Arena arena;

  for (std::size_t n = 0; n < valid.size(); ++n) {
    std::string prefix = valid.substr(0, n);
    Nested back{};
    EXPECT_FALSE(unflatten(layout, prefix.data(), prefix.size(), &back, {}, arena).ok()) << n;
  }

  std::mt19937 random(12345);
  int accepted = 0;
  for (int round = 0; round < 20000; ++round) {
    std::string mutated = valid;
    const int changes = 1 + static_cast<int>(random() % 4);
    for (int c = 0; c < changes; ++c) mutated[random() % mutated.size()] = static_cast<char>(random());
    if (random() % 8 == 0) mutated.resize(random() % (mutated.size() + 16), '\x7f');
    Nested back{};
    arena.clear();
    if (!unflatten(layout, mutated.data(), mutated.size(), &back, {}, arena).ok()) continue;
    ++accepted;
    std::string again;
    ASSERT_TRUE(flatten(layout, &back, {}, again).ok());
    ASSERT_EQ(again, mutated);
  }
  EXPECT_GT(accepted, 0);

  for (int round = 0; round < 5000; ++round) {
    std::string garbage(random() % 200, '\0');
    for (char& c : garbage) c = static_cast<char>(random());
    Nested back{};
    arena.clear();
    unflatten(layout, garbage.data(), garbage.size(), &back, {}, arena);
    unflatten(layout_of(node_sig), garbage.data(), garbage.size(), &back, {}, arena);
  }
}

}  // namespace
}  // namespace ln::services
