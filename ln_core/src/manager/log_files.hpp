// ln_logger_manager_save: a logger's recording written by the manager to a
// file on its host, in the formats of LN 2.9's manager that a native manager
// can write honestly:
//   raw     the samples of a logger with exactly one topic, back to back, as
//           downloads carry them (protocol/logger_samples.hpp)
//   pcap    LN's recorder format (what lnrecorder and LN 2.9's manager write):
//           a pcap file of link type 147 whose frames announce each topic
//           (name, definition, publisher, hash) and carry its packets with
//           the publisher's timestamps, merged by source timestamp
//   mat     MATLAB 5 (libmatio), one variable per packet field and topic,
//           named and shaped as LN 2.9's manager names them (via scipy)
//   mat4    MATLAB 4; types MATLAB 4 lacks (int8, uint32, 64-bit integers)
//           are stored as double
//   mcap    MCAP that ROS 2 tools read: the pcap, converted by ln_bag's
//           `ln bag convert` (mcap_converter.hpp), as it converts LN 2.9's
//           logger pcap files; needs ln_bag's `ln` on the manager's PATH
// "auto" picks by file name (.raw, .pcap, .mat/.matlab, .mcap). LN 2.9's default,
// a Python pickle, is refused with the reason: a native manager cannot
// write Python objects. Files appear complete or not at all (written under a
// temporary name, then renamed).
//
// To add a format: one entry in the table of log_files.cpp.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "ln/md/message_definition.hpp"
#include "manager/sample_log.hpp"

namespace ln::manager {

/// One packet field flattened to a primitive column, named as LN 2.9's
/// manager names it ("pose_position" for a field of a sub-type, "p[1]_x"
/// for one of an array of sub-types).
struct Column {
  std::string name;
  md::Primitive type = md::Primitive::Double;
  std::uint32_t count = 1;   ///< array elements
  std::uint32_t offset = 0;  ///< byte offset in the packet
};

/// The packet fields of a plain definition, flattened.
std::vector<Column> flatten_columns(const md::Definition& definition);

/// A recorded topic as the file writers need it.
struct SavedTopic {
  std::string name;
  std::string md_name;
  std::string md_text;  ///< md::python_dict_text
  std::string md_hash;
  std::string publisher;  ///< client name of its (last) publisher
  std::uint32_t message_size = 0;
  bool only_ts = false;
  std::vector<Column> columns;
  std::shared_ptr<const SampleLog> samples;  ///< null: never recorded (no publisher was seen)
};

/// The format `format` names for `filename` ("auto": by its extension), in
/// the canonical spelling of the table. Throws RequestError
/// (LNE_REQUEST_FAILED, as LN 2.9's manager refuses) naming the supported
/// formats.
std::string choose_format(const std::string& format, const std::string& filename);

/// What the mcap format needs besides the topics.
struct SaveOptions {
  std::vector<std::string> md_dirs;  ///< the manager's definition search path (for the converter)
  std::function<bool()> cancelled;   ///< polled while converting; true stops the converter
  /// The converter's environment ("NAME=VALUE"); empty: the manager's.
  std::vector<std::string> environment;
};

/// Writes `topics` to `filename` in `format` (as choose_format returns it).
/// Throws RequestError with the reason.
void save_log_file(const std::string& filename, const std::string& format, const std::vector<SavedTopic>& topics,
                   const SaveOptions& options = {});

}  // namespace ln::manager
