#include "services/call_log.hpp"

#include <chrono>

namespace ln::services {

double wall_clock_seconds() {
  return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
}

}  // namespace ln::services
