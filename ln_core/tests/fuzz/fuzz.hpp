// The fuzz suite's shared part: a seeded mutator of byte strings and the
// budget of a run. Every target starts from a corpus of valid inputs,
// mutates them, feeds the results to the code under test, and ends with a
// check that a well-behaved client is still served.
//
// Bounded and repeatable by default (CI): a fixed seed and a small number
// of rounds. On demand, longer and different:
//   LN_FUZZ_SEED=N      another seed (each failure message names the seed)
//   LN_FUZZ_ROUNDS=N    rounds per target instead of its default
//   LN_FUZZ_SECONDS=S   at most S seconds per target (default 60)
#pragma once

#include <chrono>
#include <cstdint>
#include <cstdlib>
#include <random>
#include <string>
#include <vector>

namespace ln::fuzz {

inline std::uint64_t seed() {
  const char* text = std::getenv("LN_FUZZ_SEED");
  return text && *text ? std::strtoull(text, nullptr, 10) : 18;
}

/// How many rounds a target runs and for how long at most.
class Budget {
 public:
  explicit Budget(int default_rounds)
      : rounds_(from_environment("LN_FUZZ_ROUNDS", default_rounds)),
        deadline_(std::chrono::steady_clock::now() + std::chrono::seconds(from_environment("LN_FUZZ_SECONDS", 60))) {}
  /// True while rounds and time are left; counts the round.
  bool next() {
    if (done_ >= rounds_ || std::chrono::steady_clock::now() >= deadline_) return false;
    ++done_;
    return true;
  }
  int done() const { return done_; }

 private:
  static int from_environment(const char* name, int fallback) {
    const char* text = std::getenv(name);
    const long value = text && *text ? std::strtol(text, nullptr, 10) : 0;
    return value > 0 ? static_cast<int>(value) : fallback;
  }
  int rounds_;
  int done_ = 0;
  std::chrono::steady_clock::time_point deadline_;
};

/// Byte-level mutations in the manner of coverage-blind fuzzers: flips,
/// boundary values over integers, insertions, deletions, duplicated and
/// spliced pieces, truncation.
class Mutator {
 public:
  explicit Mutator(std::uint64_t seed) : random_(seed) {}

  std::uint64_t below(std::uint64_t n) { return n == 0 ? 0 : random_() % n; }
  bool chance(int one_in) { return below(static_cast<std::uint64_t>(one_in)) == 0; }

  /// 1..8 mutations of `input`; `corpus` supplies splices.
  std::string mutate(std::string input, const std::vector<std::string>& corpus) {
    const int steps = 1 + static_cast<int>(below(8));
    for (int i = 0; i < steps; ++i) mutate_once(input, corpus);
    return input;
  }

  std::string random_bytes(std::size_t max_size) {
    std::string out(below(max_size + 1), '\0');
    for (char& c : out) c = static_cast<char>(random_());
    return out;
  }

 private:
  void mutate_once(std::string& s, const std::vector<std::string>& corpus) {
    const std::size_t at = s.empty() ? 0 : below(s.size());
    switch (below(9)) {
      case 0:  // flip a bit
        if (!s.empty()) s[at] = static_cast<char>(s[at] ^ (1 << below(8)));
        break;
      case 1:  // a random byte
        if (!s.empty()) s[at] = static_cast<char>(random_());
        break;
      case 2: {  // an interesting little-endian integer (sizes, counts, lengths)
        static const std::uint64_t values[] = {0,
                                               1,
                                               0x7f,
                                               0x80,
                                               0xff,
                                               0x100,
                                               0x7fff,
                                               0xffff,
                                               0x10000,
                                               0x7fffffff,
                                               0x80000000,
                                               0xffffffff,
                                               ~std::uint64_t{0}};
        const std::uint64_t value = values[below(sizeof values / sizeof values[0])];
        const std::size_t width = std::size_t{1} << below(4);
        for (std::size_t k = 0; k < width && at + k < s.size(); ++k) s[at + k] = static_cast<char>(value >> (8 * k));
        break;
      }
      case 3:  // insert random bytes
        s.insert(at, random_bytes(16));
        break;
      case 4:  // delete a piece
        if (!s.empty()) s.erase(at, 1 + below(std::min<std::size_t>(64, s.size() - at)));
        break;
      case 5:  // duplicate a piece
        if (!s.empty()) s.insert(at, s.substr(at, 1 + below(64)));
        break;
      case 6:  // splice in a piece of another input
        if (!corpus.empty()) {
          const std::string& other = corpus[below(corpus.size())];
          if (!other.empty()) {
            const std::size_t from = below(other.size());
            s.insert(at, other.substr(from, 1 + below(other.size() - from)));
          }
        }
        break;
      case 7:  // truncate
        s.resize(at);
        break;
      default:  // repeat a byte many times
        if (!s.empty()) s.insert(at, std::string(1 + below(512), s[at]));
        break;
    }
  }

  std::mt19937_64 random_;
};

}  // namespace ln::fuzz
