// The objects of one kind alive now, so that the C API refuses a stale or
// foreign handle instead of following it (a freed object is removed from
// the set in its destructor).
#pragma once

#include <mutex>
#include <set>

namespace ln::clientlib {

class LiveHandles {
 public:
  void add(const void* object) {
    std::lock_guard<std::mutex> lock(mutex_);
    live_.insert(object);
  }
  void remove(const void* object) {
    std::lock_guard<std::mutex> lock(mutex_);
    live_.erase(object);
  }
  bool contains(const void* handle) const {
    std::lock_guard<std::mutex> lock(mutex_);
    return live_.count(handle) != 0;
  }

 private:
  mutable std::mutex mutex_;
  std::set<const void*> live_;
};

}  // namespace ln::clientlib
