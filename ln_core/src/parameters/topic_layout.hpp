// Parameters on a topic (ln/parameters/request_parameter_topic, and blocks
// made with always_publish): the message definitions of a block's topic and
// where each parameter lies in its packets.
//
// As in LN 2.9 the packet nests like the names: parameter "ctrl.sub.gain"
// is packet.ctrl.sub.gain with the fields input, output (arrays flattened,
// row-major) and override_enabled (uint8_t); bools travel as uint8_t. The
// definitions are named gen/ln/parameters/<type>x<count>_field for the
// leaves and gen/ln/parameters/s_<hash of the text> for each level, so
// equal structures share definitions and different ones never collide.
#pragma once

#include <cstddef>
#include <string>
#include <utility>
#include <vector>

#include "parameters/values.hpp"

namespace ln::paramcore {

struct TopicField {
  std::string full_name;
  ElementType type;
  std::size_t elements;
};

struct TopicLayout {
  /// (name, text), each after the definitions it imports.
  std::vector<std::pair<std::string, std::string>> definitions;
  std::string root;                // the topic's message definition
  std::vector<std::size_t> order;  // indices of the fields in packet order
  std::size_t packet_size = 0;
  std::string error;  // not "" when the names do not form a tree (a name is also a group)
};

TopicLayout topic_layout(const std::vector<TopicField>& fields);

/// Appends one parameter to a packet: input, output, override_enabled.
void append_to_packet(std::vector<std::uint8_t>& packet, const std::vector<std::uint8_t>& input,
                      const std::vector<std::uint8_t>& output, bool override_enabled);

}  // namespace ln::paramcore
