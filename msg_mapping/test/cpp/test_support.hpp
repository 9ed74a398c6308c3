// Helpers shared by the C++ tests: in-memory LN libraries and paired types.
#pragma once

#include <cstdint>
#include <cstdlib>
#include <initializer_list>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "ln/md/message_definition.hpp"
#include "msg_mapping/codec.hpp"
#include "msg_mapping/ln_to_ros.hpp"
#include "msg_mapping/ros_to_ln.hpp"

namespace msg_mapping::test {

inline std::string data_dir() {
  const char* dir = std::getenv("MSG_MAPPING_TEST_DATA");
  return dir ? dir : MSG_MAPPING_TEST_DATA_DIR;
}

/// LN definitions given as (name, text) pairs, mapped to ROS.
struct LnFixture {
  ln::md::Library library{ln::md::SearchPath::exactly({})};
  LnToRos generator;

  LnFixture(std::initializer_list<std::pair<const char*, const char*>> sources) {
    for (const auto& [name, text] : sources) library.add_source(name, text);
  }
  LnFixture(const LnFixture&) = delete;
  LnFixture& operator=(const LnFixture&) = delete;
  const PairedInterface& add(const std::string& name) { return generator.add(library.load(name)); }
  Codec codec(const std::string& name) { return Codec(*add(name).first); }
};

inline Bytes bytes_of(const std::vector<std::uint8_t>& v) { return {v.data(), v.size()}; }

inline std::vector<std::uint8_t> hex(const std::string& text) {
  std::vector<std::uint8_t> out;
  std::string digits;
  for (char c : text)
    if (c != ' ' && c != '|') digits += c;
  for (std::size_t i = 0; i + 1 < digits.size(); i += 2)
    out.push_back(static_cast<std::uint8_t>(std::stoul(digits.substr(i, 2), nullptr, 16)));
  return out;
}

}  // namespace msg_mapping::test
