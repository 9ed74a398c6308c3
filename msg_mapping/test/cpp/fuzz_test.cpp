// Bounded fuzzing of the codecs: random and mutated LN and CDR input must either
// convert or throw CodecError, and never touch memory outside the buffers. Run
// it in the sanitizer build (-DMSG_MAPPING_SANITIZE=ON) to make the "never"
// checkable. Inputs are copied into exactly sized heap buffers so ASan sees any
// overrun. Iterations are fixed (MSG_MAPPING_FUZZ_ITERATIONS overrides).
#include <gtest/gtest.h>

#include <cstring>
#include <random>

#include "msg_mapping/codec.hpp"
#include "test_support.hpp"

namespace msg_mapping {
namespace {

using Rng = std::mt19937_64;

std::size_t iterations() {
  const char* n = std::getenv("MSG_MAPPING_FUZZ_ITERATIONS");
  return n ? std::strtoul(n, nullptr, 10) : 1000;
}

void put_u32(std::vector<std::uint8_t>& out, std::uint32_t v) {
  const auto* p = reinterpret_cast<const std::uint8_t*>(&v);
  out.insert(out.end(), p, p + 4);
}

// A valid LN flat message of `type` with random content.
void random_ln(const PairedType& type, Rng& rng, std::vector<std::uint8_t>& out, int depth);

void random_element(const PairedField& f, Rng& rng, std::vector<std::uint8_t>& out, int depth) {
  switch (f.element) {
    case ElementKind::Primitive:
      if (f.ros_primitive == RosPrimitive::Bool) {  // other values are normalized to 1 (tested elsewhere)
        out.push_back(static_cast<std::uint8_t>(rng() % 2));
        return;
      }
      for (std::size_t i = 0; i < ln::md::size_of(f.ln_primitive); ++i) out.push_back(static_cast<std::uint8_t>(rng()));
      return;
    case ElementKind::String: {
      std::uint32_t limit = f.string_capacity ? f.string_capacity : 12;
      if (f.ros_string_bound) limit = std::min(limit, f.ros_string_bound);
      const auto n = static_cast<std::uint32_t>(rng() % (std::min<std::uint32_t>(limit, 12) + 1));
      put_u32(out, n);
      for (std::uint32_t i = 0; i < n; ++i) out.push_back(static_cast<std::uint8_t>(rng()));
      if (f.string_capacity) out.insert(out.end(), f.string_capacity - n, 0);
      return;
    }
    case ElementKind::Struct:
      random_ln(*f.struct_type, rng, out, depth + 1);
      return;
  }
}

void random_ln(const PairedType& type, Rng& rng, std::vector<std::uint8_t>& out, int depth) {
  for (const PairedField& f : type.fields) {
    switch (f.shape) {
      case Shape::Single:
        random_element(f, rng, out, depth);
        break;
      case Shape::FixedArray:
        for (std::uint32_t i = 0; i < f.count; ++i) random_element(f, rng, out, depth);
        break;
      case Shape::Sequence:
      case Shape::InlineSequence: {
        std::uint32_t limit = f.shape == Shape::InlineSequence ? f.count : 4;
        if (f.ros_bound) limit = std::min(limit, f.ros_bound);
        const auto n = static_cast<std::uint32_t>(rng() % (std::min<std::uint32_t>(limit, 4) + 1));
        put_u32(out, n);
        for (std::uint32_t i = 0; i < n; ++i) random_element(f, rng, out, depth);
        if (f.shape == Shape::InlineSequence) {
          std::vector<std::uint8_t> element;
          random_element(f, rng, element, depth);
          out.insert(out.end(), (f.count - n) * element.size(), 0);
        }
        break;
      }
      case Shape::Opaque: {
        const auto n = depth < 2 ? static_cast<std::uint32_t>(rng() % 3) : 0;
        put_u32(out, n);
        for (std::uint32_t i = 0; i < n; ++i) random_ln(*f.struct_type, rng, out, depth + 1);
        break;
      }
    }
  }
}

std::vector<std::uint8_t> mutate(std::vector<std::uint8_t> data, Rng& rng) {
  switch (rng() % 6) {
    case 0:  // flip bytes
      for (int k = 0; k < 3 && !data.empty(); ++k)
        data[rng() % data.size()] ^= static_cast<std::uint8_t>(1 + rng() % 255);
      break;
    case 1:  // truncate
      data.resize(data.empty() ? 0 : rng() % data.size());
      break;
    case 2:  // append garbage
      for (int k = 0; k < 9; ++k) data.push_back(static_cast<std::uint8_t>(rng()));
      break;
    case 3:  // an impossible length somewhere
      if (data.size() >= 4) {
        const std::uint32_t huge[] = {0xffffffffu, 0x7fffffffu, 0x10000u, static_cast<std::uint32_t>(data.size())};
        std::memcpy(data.data() + rng() % (data.size() - 3), &huge[rng() % 4], 4);
      }
      break;
    case 4:  // remove a run
      if (data.size() > 2) {
        const std::size_t at = rng() % (data.size() - 1);
        data.erase(data.begin() + static_cast<std::ptrdiff_t>(at),
                   data.begin() + static_cast<std::ptrdiff_t>(std::min(data.size(), at + 1 + rng() % 8)));
      }
      break;
    default:  // random bytes
      data.resize(rng() % 64);
      for (auto& b : data) b = static_cast<std::uint8_t>(rng());
  }
  return data;
}

// Runs one conversion on an exactly sized heap copy; returns false when it threw CodecError.
template <class F>
bool survives(const std::vector<std::uint8_t>& input, F&& convert) {
  auto* copy = new std::uint8_t[input.size() + 1];  // +1: a zero-length buffer still has an address
  if (!input.empty()) std::memcpy(copy, input.data(), input.size());
  bool ok = true;
  try {
    convert(Bytes{copy, input.size()});
  } catch (const CodecError&) {
    ok = false;
  }
  delete[] copy;
  return ok;
}

void fuzz(const PairedType& type, std::uint64_t seed) {
  SCOPED_TRACE(type.ros_name);
  const Codec codec(type);
  Rng rng(seed);
  for (std::size_t i = 0; i < iterations(); ++i) {
    std::vector<std::uint8_t> ln;
    random_ln(type, rng, ln, 0);
    const std::vector<std::uint8_t> cdr = codec.ln_to_cdr(Bytes{ln.data(), ln.size()});
    ASSERT_EQ(codec.cdr_to_ln(Bytes{cdr.data(), cdr.size()}), ln);

    const auto bad_cdr = mutate(cdr, rng);
    std::vector<std::uint8_t> decoded;
    if (survives(bad_cdr, [&](Bytes b) { decoded = codec.cdr_to_ln(b); })) {
      // Whatever decodes is a valid LN message: it encodes again.
      ASSERT_TRUE(survives(decoded, [&](Bytes b) { codec.ln_to_cdr(b); })) << "decoded LN does not encode";
    }
    const auto bad_ln = mutate(ln, rng);
    survives(bad_ln, [&](Bytes b) { codec.ln_to_cdr(b); });

    // Output buffers that are too small, exactly sized on the heap.
    const std::size_t short_size = cdr.empty() ? 0 : rng() % cdr.size();
    auto* out = new std::uint8_t[short_size + 1];
    EXPECT_THROW(codec.ln_to_cdr(Bytes{ln.data(), ln.size()}, MutableBytes{out, short_size}), CodecError);
    if (!ln.empty()) {
      const std::size_t short_ln = rng() % ln.size();
      EXPECT_THROW(codec.cdr_to_ln(Bytes{cdr.data(), cdr.size()}, MutableBytes{out, std::min(short_ln, short_size)}),
                   CodecError);
    }
    delete[] out;
  }
}

TEST(CodecFuzz, LnCorpus) {
  ln::md::Library library(ln::md::SearchPath::exactly({test::data_dir() + "/ln_corpus"}));
  LnToRos generator;
  std::uint64_t seed = 1;
  for (const auto& name : definition_names_under(test::data_dir() + "/ln_corpus")) {
    if (name.rfind("mmbench/", 0) == 0) continue;  // big fixed arrays: slow under sanitizers, nothing new
    const PairedInterface& i = generator.add(library.load(name));
    fuzz(*i.first, seed++);
    if (i.second) fuzz(*i.second, seed++);
  }
}

TEST(CodecFuzz, RosTypes) {
  RosToLn ros({test::data_dir() + "/ros_share"});
  std::uint64_t seed = 100;
  for (const char* type : {"mm_test_msgs/msg/Bounded", "mm_test_msgs/msg/Inner", "mm_test_msgs/msg/Nothing"}) {
    fuzz(*ros.add(type, false).first, seed++);
    fuzz(*ros.add(type, true).first, seed++);
  }
  const PairedInterface& service = ros.add("mm_test_msgs/srv/Lookup");
  fuzz(*service.first, seed++);
  fuzz(*service.second, seed++);
}

TEST(CodecFuzz, PureGarbage) {
  test::LnFixture ln({{"t/dyn", "define p as \"t/pair\"\np* items\nchar* s\ndouble* d\n"},
                      {"t/pair", "uint8_t a\nchar* s\ndefine p as \"t/pair\"\np* kids\n"}});
  const Codec codec = ln.codec("t/dyn");
  Rng rng(7);
  for (std::size_t i = 0; i < 20 * iterations(); ++i) {
    std::vector<std::uint8_t> data(rng() % 48);
    for (auto& b : data) b = static_cast<std::uint8_t>(rng() % 4 == 0 ? rng() : rng() % 3);
    if (i % 2 && data.size() >= 2) data[0] = 0, data[1] = 1;  // a valid header half of the time
    survives(data, [&](Bytes b) { codec.cdr_to_ln(b); });
    survives(data, [&](Bytes b) { codec.ln_to_cdr(b); });
  }
}

}  // namespace
}  // namespace msg_mapping
