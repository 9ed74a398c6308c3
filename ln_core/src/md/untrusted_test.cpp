// Definitions from anyone (a manager parses what every client puts): large
// or cunningly nested texts cost time in proportion to their size, or are
// refused with a clear error, never a minute of parsing.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <random>
#include <string>
#include <vector>

#include "ln/md/message_definition.hpp"
#include "md/test_support.hpp"

namespace ln::md {
namespace {

using testing::DefinitionTree;
using testing::load_error;
using Clock = std::chrono::steady_clock;

// Fails with the error's text if loading `name` throws.
const Definition& load(Library& library, const std::string& name) {
  try {
    return library.load(name);
  } catch (const Error& e) {
    ADD_FAILURE() << e.what();
    throw;
  }
}

double seconds_since(Clock::time_point start) { return std::chrono::duration<double>(Clock::now() - start).count(); }

// The order of fields LN 2.9 produces, by its own method (a scan of the
// list per dynamic field, remove and insert by index): the reference for
// the linear-time placement of the `_len` fields.
std::vector<std::string> ln29_field_order(std::vector<std::string> names, const std::vector<std::string>& dynamic) {
  for (const std::string& x : dynamic) {
    const auto i = std::find(names.begin(), names.end(), x) - names.begin();
    const auto found = std::find(names.begin(), names.end(), x + "_len");
    if (found == names.end()) {
      names.insert(names.begin() + i, x + "_len");
      continue;
    }
    const auto k = found - names.begin();
    if (k == i - 1) continue;
    names.erase(found);
    names.insert(names.begin() + i, x + "_len");
  }
  return names;
}

TEST(UntrustedDefinitions, LengthFieldsGoWhereLn29PutsThem) {
  std::mt19937 random(20240518);
  for (int round = 0; round < 300; ++round) {
    // Fields d0..dn (some dynamic), some of the dynamic ones with their
    // _len declared somewhere, all shuffled.
    std::vector<std::string> lines, names, dynamic;
    const int count = 1 + static_cast<int>(random() % 12);
    for (int i = 0; i < count; ++i) {
      const std::string name = "d" + std::to_string(i);
      const bool is_dynamic = random() % 2 == 0;
      lines.push_back((is_dynamic ? "double* " : "int32_t ") + name);
      if (is_dynamic && random() % 3 != 0) lines.push_back("uint32_t " + name + "_len");
    }
    std::shuffle(lines.begin(), lines.end(), random);
    std::string text;
    for (const std::string& line : lines) {
      text += line + "\n";
      names.push_back(line.substr(line.find(' ') + 1));
      if (line.find('*') != std::string::npos) dynamic.push_back(names.back());
    }
    DefinitionTree tree;
    tree.write("t/shuffled", text);
    Library library(SearchPath::exactly({tree.root()}));
    std::vector<std::string> got;
    for (const Field& f : load(library, "t/shuffled").fields) got.push_back(f.name);
    EXPECT_EQ(got, ln29_field_order(names, dynamic)) << text;
  }
}

TEST(UntrustedDefinitions, ManyFieldsTakeLinearTime) {
  // Quadratic checks took 37 s for 97 000 fields (issue 18); 240 000
  // fields, a third dynamic with their _len before, after or missing.
  std::string text;
  constexpr int count = 80000;
  for (int i = 0; i < count; ++i) {
    const std::string n = std::to_string(i);
    text += "double* a" + n + "\n";
    if (i % 2 == 0) text += "uint32_t a" + n + "_len\n";
    text += "int8_t b" + n + "\nuint16_t c" + n + "\n";
  }
  DefinitionTree tree;
  tree.write("t/big", text);
  Library library(SearchPath::exactly({tree.root()}));
  const auto start = Clock::now();
  const Definition& def = load(library, "t/big");
  EXPECT_EQ(def.fields.size(), 4u * count);
  EXPECT_EQ(packet_size(def), 3u * count + 4u * count);  // b, c and every a_len
  // Generous for sanitizer builds on a busy 2-core machine; the quadratic
  // checks needed minutes for this.
  EXPECT_LT(seconds_since(start), 20.0);
}

TEST(UntrustedDefinitions, DuplicateFieldsAreNamedWithTheirFirstLine) {
  DefinitionTree tree;
  tree.write("t/dup", "double x\nint32_t y\n# a comment\nfloat x\n");
  EXPECT_NE(load_error(tree, "t/dup").find(":4: field 'x' is already defined in line 1"), std::string::npos)
      << load_error(tree, "t/dup");
  tree.write("t/dup_response", "service\nrequest\nint32_t x\nresponse\nint32_t x\nint8_t x\n");
  EXPECT_NE(load_error(tree, "t/dup_response").find(":6: field 'x' is already defined in line 5"), std::string::npos);
}

TEST(UntrustedDefinitions, TooManyDefinesAreRefused) {
  DefinitionTree tree;
  tree.write("t/leaf", "double x\n");
  std::string text;
  for (int i = 0; i < 257; ++i) text += "define t" + std::to_string(i) + " as \"leaf\"\n";
  tree.write("t/many", text + "double y\n");
  EXPECT_NE(load_error(tree, "t/many").find(":257: more than 256 'define's in one definition"), std::string::npos)
      << load_error(tree, "t/many");
}

// Level i holds level i-1 twice: a few small files that describe 2^levels
// fields once written out, as layouts, signatures and the hash do.
void write_doubling_levels(const DefinitionTree& tree, int levels, bool with_fields) {
  tree.write("t/l0", "double x\n");
  for (int i = 1; i <= levels; ++i) {
    const std::string below = "l" + std::to_string(i - 1);
    std::string text = "define a as \"" + below + "\"\ndefine b as \"" + below + "\"\n";
    text += with_fields ? "a first\nb second\n" : "uint8_t flag\n";
    tree.write("t/l" + std::to_string(i), text);
  }
}

TEST(UntrustedDefinitions, SharedImportsAreMeasuredOnce) {
  DefinitionTree tree;
  write_doubling_levels(tree, 12, true);
  Library library(SearchPath::exactly({tree.root()}));
  const Definition& def = load(library, "t/l12");
  EXPECT_EQ(packet_size(def), 8u << 12);
  EXPECT_EQ(def.hash.size(), 64u);
}

TEST(UntrustedDefinitions, ExponentiallyNestedFieldsAreRefused) {
  DefinitionTree tree;
  write_doubling_levels(tree, 40, true);
  const auto start = Clock::now();
  const std::string error = load_error(tree, "t/l40");
  EXPECT_NE(error.find("fields with its sub-types written out"), std::string::npos) << error;
  EXPECT_LT(seconds_since(start), 20.0);
}

TEST(UntrustedDefinitions, ExponentiallyNestedImportsAreRefused) {
  DefinitionTree tree;
  write_doubling_levels(tree, 40, false);  // defines only: the hash follows every import
  const auto start = Clock::now();
  const std::string error = load_error(tree, "t/l40");
  EXPECT_NE(error.find("imports more than 100000 types"), std::string::npos) << error;
  EXPECT_LT(seconds_since(start), 20.0);
}

}  // namespace
}  // namespace ln::md
