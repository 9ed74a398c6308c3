// manager_save's "mcap" format: the manager writes LN's recorder pcap (as
// for "pcap") and has ln_bag's converter turn it into MCAP, so that the
// project keeps one MCAP writer, in ln_bag (which builds on ln_core, not the
// other way round). The converter is `ln bag convert`, run as a child of the
// manager (in the loggers' worker thread, bounded in time, with the manager's
// environment), through LN's `ln` command found on the manager's PATH. It
// writes the channels `ln record` writes: ROS 2 types from msg_mapping, CDR
// messages, the LN definition in the channel metadata.
#pragma once

#include <chrono>
#include <functional>
#include <string>
#include <vector>

namespace ln::manager {

/// LN's `ln` command on the search path `path` (a PATH value): the first file
/// named ln that is a script (ln_core's launcher or a pip console script),
/// not coreutils' ln (a binary). "" when there is none.
std::string find_ln_command(const std::string& path);

struct McapConversion {
  std::string pcap;                      ///< the input, a recorder pcap file
  std::string mcap;                      ///< the output file (replaced if it exists)
  std::string target;                    ///< the file the user asked for (for messages)
  std::vector<std::string> md_dirs;      ///< definition directories for --md-dir
  std::vector<std::string> environment;  ///< "NAME=VALUE", the converter's whole environment
  std::chrono::milliseconds timeout{0};
  std::function<bool()> cancelled;  ///< polled; true stops the converter
};

/// Runs the converter and waits for it. Throws RequestError (LNE_REQUEST_FAILED)
/// naming what is missing, the converter's own message, or that it took too
/// long (it is killed then).
void convert_pcap_to_mcap(const McapConversion& conversion);

}  // namespace ln::manager
