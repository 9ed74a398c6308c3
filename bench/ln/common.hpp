// Shared helpers of the LN benchmark programs in bench/ln/. The programs use
// only the LN 2.9 C++ API (plus, under LN_CORE_EXTENSIONS, ln_core's
// zero-copy read) and are compiled twice: against LN 2.9 and against ln_core.
//
// Conventions (bench/README.md): one JSON object per result line on stdout;
// a "server" side prints {"ready": true} once it is set up, so the harness
// starts the measuring side only then; a failure prints
// {"ok": false, "error": "...", "not_implemented": bool} and exits 2.
// Every loop is bounded in count and time.
#pragma once

#include <ln/ln.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <initializer_list>
#include <map>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace bench {

using Clock = std::chrono::steady_clock;

inline double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

// A measurement that cannot be trusted (wrong answer, lost echo, timeout).
struct Failure : std::runtime_error {
  using std::runtime_error::runtime_error;
};

inline std::string json_escape(const std::string& s) {
  std::string out;
  for (char c : s) {
    if (c == '"' || c == '\\') {
      out += '\\';
      out += c;
    } else if (static_cast<unsigned char>(c) < 0x20) {
      char buf[8];
      std::snprintf(buf, sizeof buf, "\\u%04x", c);
      out += buf;
    } else {
      out += c;
    }
  }
  return out;
}

// Builds one JSON object line: Json().num("a", 1).str("b", "x").print().
class Json {
 public:
  Json& num(const std::string& key, double v) {
    char buf[64];
    if (std::isfinite(v))
      std::snprintf(buf, sizeof buf, "%.6g", v);
    else
      std::snprintf(buf, sizeof buf, "null");
    return raw(key, buf);
  }
  Json& integer(const std::string& key, long long v) { return raw(key, std::to_string(v)); }
  Json& str(const std::string& key, const std::string& v) { return raw(key, "\"" + json_escape(v) + "\""); }
  Json& boolean(const std::string& key, bool v) { return raw(key, v ? "true" : "false"); }
  Json& raw(const std::string& key, const std::string& v) {
    body_ += (body_.empty() ? "" : ", ") + ("\"" + key + "\": ") + v;
    return *this;
  }
  void print() const {
    std::printf("{%s}\n", body_.c_str());
    std::fflush(stdout);
  }

 private:
  std::string body_;
};

inline void print_ready() { Json().boolean("ready", true).print(); }

// Distribution of latencies in microseconds.
struct Stats {
  double median = 0, p99 = 0, p90 = 0, min = 0, max = 0, mean = 0;
  size_t n = 0;
};

inline Stats stats_of(std::vector<double> v) {
  Stats s;
  s.n = v.size();
  if (v.empty()) return s;
  std::sort(v.begin(), v.end());
  auto at = [&](double q) { return v[std::min(v.size() - 1, static_cast<size_t>(q * (v.size() - 1) + 0.5))]; };
  s.median = at(0.5);
  s.p90 = at(0.9);
  s.p99 = at(0.99);
  s.min = v.front();
  s.max = v.back();
  double sum = 0;
  for (double x : v) sum += x;
  s.mean = sum / v.size();
  return s;
}

inline Json& add_stats(Json& j, const Stats& s, const std::string& unit = "us") {
  return j.integer("n", static_cast<long long>(s.n))
      .num("median_" + unit, s.median)
      .num("p90_" + unit, s.p90)
      .num("p99_" + unit, s.p99)
      .num("min_" + unit, s.min)
      .num("max_" + unit, s.max)
      .num("mean_" + unit, s.mean);
}

// "--key value" options after a role word: prog ROLE [--key value]...
class Args {
 public:
  Args(int argc, char** argv) {
    if (argc < 2) throw std::invalid_argument("missing role");
    role_ = argv[1];
    for (int i = 2; i < argc; ++i) {
      std::string a = argv[i];
      if (a.rfind("--", 0) != 0 || i + 1 >= argc) throw std::invalid_argument("bad argument '" + a + "'");
      values_[a.substr(2)] = argv[++i];
    }
  }
  const std::string& role() const { return role_; }
  std::string str(const std::string& key, const std::string& def) const {
    auto it = values_.find(key);
    return it == values_.end() ? def : it->second;
  }
  long integer(const std::string& key, long def) const {
    auto it = values_.find(key);
    return it == values_.end() ? def : std::strtol(it->second.c_str(), nullptr, 0);
  }
  double real(const std::string& key, double def) const {
    auto it = values_.find(key);
    return it == values_.end() ? def : std::strtod(it->second.c_str(), nullptr);
  }

 private:
  std::string role_;
  std::map<std::string, std::string> values_;
};

// Payload pattern. Word k of a packet of `size` bytes stamped with `seq` is
// pattern(seq, k). Packets up to 4 KiB carry the pattern in every word; larger
// ones in word 0, the first word of every 4 KiB page and the last word, so a
// 1 MiB check costs ~260 loads while still catching a stale or torn page.
inline uint32_t pattern(uint32_t seq, uint32_t word) { return seq * 2654435761u + word * 40503u; }

template <typename F>
inline void for_each_stamp(size_t size, F&& f) {
  const size_t words = size / 4;
  if (size <= 4096) {
    for (size_t k = 1; k < words; ++k) f(k);
  } else {
    for (size_t k = 1024; k < words; k += 1024) f(k);
    f(words - 1);
  }
}

// Word 0 is the sequence number itself (the `seq` field of lnbench/p*).
inline void stamp(void* packet, size_t size, uint32_t seq) {
  auto* w = static_cast<uint32_t*>(packet);
  w[0] = seq;
  for_each_stamp(size, [&](size_t k) { w[k] = pattern(seq, static_cast<uint32_t>(k)); });
}

// Zero-copy echo: only word 0 (seq) and the last payload word travel back.
inline void copy_ends(void* dst, const void* src, size_t size) {
  auto* d = static_cast<uint32_t*>(dst);
  const auto* s = static_cast<const uint32_t*>(src);
  d[0] = s[0];
  d[size / 4 - 1] = s[size / 4 - 1];
}

inline std::string check_ends(const void* packet, size_t size, uint32_t seq) {
  const auto* w = static_cast<const uint32_t*>(packet);
  if (w[0] != seq) return "seq " + std::to_string(w[0]) + " instead of " + std::to_string(seq);
  if (w[size / 4 - 1] != pattern(seq, static_cast<uint32_t>(size / 4 - 1)))
    return "last payload word of packet " + std::to_string(seq) + " is wrong (stale)";
  return "";
}

// Empty string when the packet carries seq's pattern, else what is wrong.
inline std::string check_stamp(const void* packet, size_t size, uint32_t seq) {
  const auto* w = static_cast<const uint32_t*>(packet);
  if (w[0] != seq) return "seq " + std::to_string(w[0]) + " instead of " + std::to_string(seq);
  std::string bad;
  for_each_stamp(size, [&](size_t k) {
    if (bad.empty() && w[k] != pattern(seq, static_cast<uint32_t>(k)))
      bad = "payload word " + std::to_string(k) + " of packet " + std::to_string(seq) + " is wrong (torn or stale)";
  });
  return bad;
}

inline bool is_not_implemented(const ln::exception& e) {
#ifdef LN_CORE_EXTENSIONS
  if (e.error == LNE_NOT_YET_IMPLEMENTED) return true;
#endif
  return e.msg.find("not yet implemented") != std::string::npos ||
         e.msg.find("NOT_YET_IMPLEMENTED") != std::string::npos;
}

// main() body wrapper: runs f, turns failures into the error line.
template <typename F>
int guarded_main(F&& f) {
  try {
    return f();
  } catch (const ln::exception& e) {
    Json()
        .boolean("ok", false)
        .str("error", std::string("LN error: ") + e.what())
        .boolean("not_implemented", is_not_implemented(e))
        .print();
  } catch (const std::exception& e) {
    Json().boolean("ok", false).str("error", e.what()).boolean("not_implemented", false).print();
  }
  return 2;
}

// main() of a program with roles, `prog ROLE [--key value]...`: prepare(args) (when given), then a
// client named client_prefix + ROLE runs the role's function; failures become the error line.
using Role = int (*)(ln::client&, const Args&);
inline int role_main(int argc, char** argv, const std::string& client_prefix,
                     std::initializer_list<std::pair<const char*, Role>> roles,
                     void (*prepare)(const Args&) = nullptr) {
  return guarded_main([&] {
    Args args(argc, argv);
    if (prepare != nullptr) prepare(args);
    std::string names;
    for (const auto& role : roles) {
      if (args.role() == role.first) {
        ln::client clnt(client_prefix + args.role());
        return role.second(clnt, args);
      }
      names += (names.empty() ? "" : " or ") + std::string(role.first);
    }
    throw std::invalid_argument("role must be " + names);
  });
}

// A lnbench/p64 packet (msgdefs/lnbench/p64): sequence number + payload.
struct Packet64 {
  uint32_t seq;
  uint8_t pad[60];
};
static_assert(sizeof(Packet64) == 64, "lnbench/p64 is 64 bytes");

constexpr uint32_t kHandshake = 0xfffffff0u;
constexpr uint32_t kStop = 0xffffffffu;

inline const char* md_for_size(long size) {
  switch (size) {
    case 64:
      return "lnbench/p64";
    case 4096:
      return "lnbench/p4k";
    case 1048576:
      return "lnbench/p1m";
    default:
      throw std::invalid_argument("size must be 64, 4096 or 1048576");
  }
}

}  // namespace bench
