// Deliberate network faults for the multi-host tests, where the kernel has no
// netem: UDP datagrams dropped, duplicated and reordered on the sender's side.
// libln itself never injects any (datagram_faults_none.cpp, part of
// ln_client_objects); the test copy of the library that the remote test
// programs link (tests/remote) adds datagram_faults.cpp, driven by
// LN_CORE_TEST_UDP_FAULTS, whose definition replaces the weak one.
#pragma once

#include <cstddef>
#include <functional>
#include <memory>

namespace ln::clientlib {

/// Sends one datagram made of a header and a payload; false on a send error.
using SendDatagram = std::function<bool(const unsigned char* header, const unsigned char* payload, std::size_t length)>;

class DatagramFaults {
 public:
  virtual ~DatagramFaults() = default;
  /// Sends the datagram through `send`, or drops, duplicates or holds it back.
  virtual bool send(const unsigned char* header, std::size_t header_size, const unsigned char* payload,
                    std::size_t length, const SendDatagram& send) = 0;
};

/// The faults the environment asks for, or nullptr (always, in libln).
std::unique_ptr<DatagramFaults> datagram_faults_from_environment();

}  // namespace ln::clientlib
