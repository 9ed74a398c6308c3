// Test builds only (see datagram_faults.hpp):
// LN_CORE_TEST_UDP_FAULTS="drop=K,duplicate=M,reorder=N" makes every K-th UDP
// datagram vanish, every M-th go out twice, and every N-th go out after the
// one following it.
#include "client/datagram_faults.hpp"

#include <cstdint>
#include <cstdlib>
#include <sstream>
#include <string>
#include <vector>

namespace ln::clientlib {
namespace {

class EveryNth : public DatagramFaults {
 public:
  std::uint64_t drop = 0, duplicate = 0, reorder = 0;

  bool send(const unsigned char* header, std::size_t header_size, const unsigned char* payload, std::size_t length,
            const SendDatagram& send_one) override {
    const std::uint64_t n = ++count_;
    if (drop != 0 && n % drop == 0) return true;
    if (reorder != 0 && n % reorder == 0 && delayed_.empty()) {
      delayed_header_size_ = header_size;
      delayed_.assign(header, header + header_size);
      delayed_.insert(delayed_.end(), payload, payload + length);
      return true;
    }
    const bool sent = send_one(header, payload, length);
    if (duplicate != 0 && n % duplicate == 0) send_one(header, payload, length);
    if (!delayed_.empty()) {
      send_one(delayed_.data(), delayed_.data() + delayed_header_size_, delayed_.size() - delayed_header_size_);
      delayed_.clear();
    }
    return sent;
  }

 private:
  std::uint64_t count_ = 0;
  std::vector<unsigned char> delayed_;
  std::size_t delayed_header_size_ = 0;
};

}  // namespace

std::unique_ptr<DatagramFaults> datagram_faults_from_environment() {
  const char* text = std::getenv("LN_CORE_TEST_UDP_FAULTS");
  if (text == nullptr || *text == '\0') return nullptr;
  auto faults = std::make_unique<EveryNth>();
  std::istringstream in(text);
  std::string item;
  while (std::getline(in, item, ',')) {
    const auto equals = item.find('=');
    if (equals == std::string::npos) continue;
    const std::uint64_t every = std::strtoull(item.c_str() + equals + 1, nullptr, 10);
    const std::string name = item.substr(0, equals);
    if (name == "drop")
      faults->drop = every;
    else if (name == "duplicate")
      faults->duplicate = every;
    else if (name == "reorder")
      faults->reorder = every;
  }
  return faults;
}

}  // namespace ln::clientlib
