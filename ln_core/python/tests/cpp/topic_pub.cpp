// Mixed-language test: C++ publisher of pytest/all_types (u32 = 1, 2, ...).
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <thread>

#include "test_messages.h"

int main(int argc, char** argv) {
  ln::client clnt("cpp_topic_pub", argc, argv);
  const int n = std::atoi(argv[2]);
  ln::outport* port = clnt.publish(argv[1], PYTEST_ALL_TYPES_MD_NAME);
  pytest_all_types_t p;
  std::memset(&p, 0, sizeof p);
  // The subscriber first (it is there before this program starts; the wait is bounded).
  const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(20);
  while (!port->has_subscriber() && std::chrono::steady_clock::now() < until) {
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  for (int i = 1; i <= n; ++i) {
    p.u32 = static_cast<uint32_t>(i);
    p.d = i * 0.5;
    p.vec[2] = -i;
    std::snprintf(p.name, sizeof p.name, "cpp%d", i);
    p.corners[1].y = 3.25;
    port->write(&p, 100.0 + i);
    std::this_thread::sleep_for(std::chrono::milliseconds(50));  // a publisher at 20 Hz
  }
  return 0;
}
