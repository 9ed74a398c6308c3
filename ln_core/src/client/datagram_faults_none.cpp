// libln's side of datagram_faults.hpp: no faults, whatever the environment
// says. Weak, so that a program or library that also links
// datagram_faults.cpp (the test copy of libln) gets that one instead, while
// everything linking ln_client_objects alone needs nothing more.
#include "client/datagram_faults.hpp"

namespace ln::clientlib {

__attribute__((weak)) std::unique_ptr<DatagramFaults> datagram_faults_from_environment() { return nullptr; }

}  // namespace ln::clientlib
