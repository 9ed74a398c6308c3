// libln's side of datagram_faults.hpp: no faults, whatever the environment says.
#include "client/datagram_faults.hpp"

namespace ln::clientlib {

std::unique_ptr<DatagramFaults> datagram_faults_from_environment() { return nullptr; }

}  // namespace ln::clientlib
