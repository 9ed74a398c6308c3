// links_and_nodes._ln: the client (ln_init, ln_deinit and the calls on an
// ln_client). Its handles (ports, services, ...) share its ClientState.
#pragma once

#include <nanobind/stl/map.h>
#include <nanobind/stl/optional.h>
#include <nanobind/stl/string.h>
#include <nanobind/stl/vector.h>

#include <chrono>
#include <map>
#include <mutex>
#include <optional>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include "common.hpp"
#include "model.hpp"

namespace lnpy {

// ---------------------------------------------------------------- client

std::optional<std::string> take_string(char* text);

struct AvailabilityHandler {
  nb::object callback;
};

void availability_trampoline(ln_client, const char* name, int available, void* user);

class Client {
 public:
  Client(const std::string& name, std::optional<std::string> manager, std::optional<std::vector<std::string>> argv)
      : state_(std::make_shared<ClientState>()) {
    require_no_nul(name, "the client name");
    require_no_nul(manager, "the manager address");
    int ret;
    ln_client handle = nullptr;
    if (argv) {
      std::vector<char*> args;
      for (auto& a : *argv) args.push_back(a.data());
      args.push_back(nullptr);
      nb::gil_scoped_release release;
      ret = ln_init(&handle, name.c_str(), static_cast<int>(argv->size()), args.data());
    } else {
      nb::gil_scoped_release release;
      ret = ln_init_to_manager(&handle, name.c_str(), manager ? manager->c_str() : nullptr);
    }
    if (ret < 0) {
      // no client to ask: ln_get_error_message(NULL) tells why ln_init failed (ln_core)
      std::string message = "cannot create client '" + name + "': " + ln_format_error(ret);
      const char* detail = ln_get_error_message(nullptr);
      if (detail != nullptr && *detail != '\0' && ret != -LNE_CHECK_ERRNO) message += ": " + std::string(detail);
      throw Failure{-ret, message};
    }
    state_->handle = handle;
  }
  ~Client() {
    try {
      close();
    } catch (...) {
    }
  }

  void close() {
    ln_client handle = state_->handle;
    if (handle == nullptr) return;
    if (state_->loans.load() != 0)
      throw Failure{LNE_INVALID_PARAMETER, "borrowed packets are still in use: release them before closing the client"};
    {
      std::lock_guard<std::mutex> lock(state_->mutex);
      for (ln_inport port : state_->inports) ln_unblock(port);
      for (const std::string& group : state_->groups_waiting) ln_unblock_service_group(handle, group.c_str());
    }
    state_->handle = nullptr;  // new calls fail from here on
    {
      // Running handlers need the GIL to finish; deinit waits for them.
      nb::gil_scoped_release release;
      while (state_->busy.load() != 0) std::this_thread::sleep_for(std::chrono::milliseconds(1));
      ln_deinit(&handle);
    }
    for (AvailabilityHandler* h : handlers_) delete h;
    handlers_.clear();
    named_handlers_.clear();
  }

  bool closed() const { return state_->handle == nullptr; }
  const StatePtr& state() const { return state_; }
  ln_client handle() const { return state_->handle; }

  std::string name() {
    Use use(*state_);
    char* name = nullptr;
    ln_client_get_name(state_->handle, &name);
    return name ? name : "";
  }

  std::vector<std::string> remaining_args() {
    Use use(*state_);
    unsigned int n = 0;
    char* args = nullptr;
    check(ln_get_remaining_args(state_->handle, &n, &args), "get_remaining_args");
    std::vector<std::string> out;
    for (unsigned int i = 0; i < n && args != nullptr; ++i) {
      out.emplace_back(args);
      args += out.back().size() + 1;
    }
    return out;
  }

  double ping(double timeout) {
    Use use(*state_);
    double rtt = 0;
    const int ret = without_gil([&] { return ln_ping(state_->handle, timeout, &rtt); });
    check(ret, "ping");
    return rtt;
  }

  nb::tuple get_message_definition(const std::string& name) {
    require_no_nul(name, "the message definition name");
    Use use(*state_);
    char *md = nullptr, *hash = nullptr, *flat = nullptr;
    unsigned int size = 0;
    const int ret = without_gil(
        [&] { return ln_get_message_definition_v21(state_->handle, name.c_str(), &md, &size, &hash, &flat); });
    check(ret, "get_message_definition('" + name + "')");
    auto text = take_string(md);
    auto hash_text = take_string(hash);
    auto flat_text = take_string(flat);
    return nb::make_tuple(text.value_or(""), size, hash_text.value_or(""), flat_text.value_or(""));
  }

  nb::tuple get_message_definition_for_topic(const std::string& topic) {
    require_no_nul(topic, "the topic name");
    Use use(*state_);
    char *md_name = nullptr, *md = nullptr, *hash = nullptr;
    unsigned int size = 0;
    const int ret = without_gil([&] {
      return ln_get_message_definition_for_topic_v17(state_->handle, topic.c_str(), &md_name, &md, &size, &hash);
    });
    check(ret, "get_message_definition_for_topic('" + topic + "')");
    auto n = take_string(md_name);
    auto t = take_string(md);
    auto h = take_string(hash);
    return nb::make_tuple(n.value_or(""), t.value_or(""), size, h.value_or(""));
  }

  std::string describe_message_definition(const std::string& name) {
    require_no_nul(name, "the message definition name");
    Use use(*state_);
    char* text = nullptr;
    check(ln_describe_message_definition(state_->handle, name.c_str(), &text), "describe_message_definition");
    return take_string(text).value_or("");
  }

  std::string put_message_definition(const std::string& name, const std::string& text) {
    require_no_nul(name, "the message definition name");
    require_no_nul(text, "the message definition text");
    Use use(*state_);
    char* real = nullptr;
    check(ln_put_message_definition(state_->handle, name.c_str(), text.c_str(), &real), "put_message_definition");
    return take_string(real).value_or(name);
  }

  nb::tuple locate_member(const std::string& md_name, const std::string& member) {
    require_no_nul(md_name, "the message definition name");
    require_no_nul(member, "the member");
    Use use(*state_);
    unsigned int offset = 0, length = 0;
    check(ln_locate_member_in_message_definition(state_->handle, md_name.c_str(), member.c_str(), &offset, &length),
          "locate_member_in_message_definition");
    return nb::make_tuple(offset, length);
  }

  // The model of a definition as the manager knows it (or of `text`).
  nb::dict model(const std::string& name, std::optional<std::string> text) {
    require_no_nul(name, "the message definition name");
    require_no_nul(text, "the message definition text");
    Use use(*state_);
    ln_client handle = state_->handle;
    if (!text) {  // the manager's error (LN 2.9: LNE_REQUEST_FAILED) for an unknown definition
      char* md = nullptr;
      unsigned int size = 0;
      const int ret = ln_get_message_definition(handle, name.c_str(), &md, &size);
      if (ret < 0) fail(ret, "get_message_definition " + name, handle);
      text = take_string(md);
    }
    return build_model(name, text, [handle](const std::string& wanted) -> std::optional<std::string> {
      char* md = nullptr;
      unsigned int size = 0;
      if (ln_get_message_definition(handle, wanted.c_str(), &md, &size) < 0) return std::nullopt;
      return take_string(md);
    });
  }

  nb::tuple get_service_signature(const std::string& interface) {
    require_no_nul(interface, "the service interface");
    Use use(*state_);
    char *definition = nullptr, *signature = nullptr;
    const int ret = without_gil(
        [&] { return ln_get_service_signature(state_->handle, interface.c_str(), &definition, &signature); });
    check(ret, "get_service_signature('" + interface + "')");
    auto d = take_string(definition);
    auto s = take_string(signature);
    return nb::make_tuple(d.value_or(""), s.value_or(""));
  }

  nb::tuple get_service_signature_for_service(const std::string& service) {
    require_no_nul(service, "the service name");
    Use use(*state_);
    char *interface = nullptr, *definition = nullptr, *signature = nullptr;
    const int ret = without_gil([&] {
      return ln_get_service_signature_for_service(state_->handle, service.c_str(), &interface, &definition, &signature);
    });
    check(ret, "get_service_signature_for_service('" + service + "')");
    auto i = take_string(interface);
    auto d = take_string(definition);
    auto s = take_string(signature);
    return nb::make_tuple(i.value_or(""), d.value_or(""), s.value_or(""));
  }

  std::vector<std::string> find_services_with_interface(const std::string& interface) {
    require_no_nul(interface, "the service interface");
    Use use(*state_);
    char* services = nullptr;
    check(ln_client_find_services_with_interface(state_->handle, interface.c_str(), &services),
          "find_services_with_interface");
    std::string all = take_string(services).value_or("");
    std::vector<std::string> out;
    std::size_t start = 0;
    while (start < all.size()) {
      std::size_t end = all.find('\n', start);
      if (end == std::string::npos) end = all.size();
      if (end > start) out.push_back(all.substr(start, end - start));
      start = end + 1;
    }
    return out;
  }

  void needs_provider(const std::string& name, double timeout) {
    require_no_nul(name, "the service or topic name");
    Use use(*state_);
    const int ret = without_gil([&] { return ln_needs_provider(state_->handle, name.c_str(), timeout); });
    check(ret, "needs_provider('" + name + "')");
  }

  bool wait_for_service(const std::string& name, double timeout) {
    require_no_nul(name, "the service name");
    Use use(*state_);
    const int ret = wait_in_slices(timeout, state_.get(), [&](double slice) {
      const int r = ln_wait_for_service(state_->handle, name.c_str(), slice);
      return r;
    });
    check(ret, "wait_for_service('" + name + "')");
    return ret > 0;
  }

  void wait_and_handle_service_group_requests(std::optional<std::string> group, double timeout) {
    require_no_nul(group, "the service group name");
    Use use(*state_);
    const char* group_name = group ? group->c_str() : nullptr;
    {
      std::lock_guard<std::mutex> lock(state_->mutex);
      state_->groups_waiting.insert(group.value_or(""));
    }
    struct Done {
      ClientState& s;
      std::string g;
      ~Done() {
        std::lock_guard<std::mutex> lock(s.mutex);
        s.groups_waiting.erase(g);
      }
    } done{*state_, group.value_or("")};
    // Handling runs Python handlers (they take the GIL themselves). Like
    // LN's single call, return once requests were handled (or on timeout).
    // As in wait_in_slices, the clock is read only to end a finite wait.
    const std::uint64_t handled_before = state_->handled.load();
    const bool forever = timeout < 0;
    const double deadline = forever ? INFINITY : now() + timeout;
    double slice = forever ? kSlice : std::min(kSlice, timeout);
    for (;;) {
      const int ret =
          without_gil([&] { return ln_wait_and_handle_service_group_requests(state_->handle, group_name, slice); });
      if (ret < 0) fail(ret, "wait_and_handle_service_group_requests", state_->handle);
      if (timeout == 0 || state_->handled.load() != handled_before) return;
      if (PyErr_CheckSignals() != 0) throw nb::python_error();
      if (state_->handle == nullptr) return;
      if (!forever) {
        const double remaining = deadline - now();
        if (remaining <= 0) return;
        slice = std::min(kSlice, remaining);
      }
    }
  }

  void handle_service_group_in_thread_pool(std::optional<std::string> group, const std::string& pool) {
    require_no_nul(group, "the service group name");
    require_no_nul(pool, "the thread pool name");
    Use use(*state_);
    check(ln_handle_service_group_in_thread_pool(state_->handle, group ? group->c_str() : nullptr, pool.c_str()),
          "handle_service_group_in_thread_pool");
  }
  void remove_service_group_from_thread_pool(std::optional<std::string> group) {
    require_no_nul(group, "the service group name");
    Use use(*state_);
    nb::gil_scoped_release release;  // waits for running handlers, which need the GIL
    check_nogil(ln_remove_service_group_from_thread_pool(state_->handle, group ? group->c_str() : nullptr),
                "remove_service_group_from_thread_pool");
  }
  void unblock_service_group(std::optional<std::string> group) {
    require_no_nul(group, "the service group name");
    Use use(*state_);
    check(ln_unblock_service_group(state_->handle, group ? group->c_str() : nullptr), "unblock_service_group");
  }
  void set_max_threads(const std::string& pool, unsigned int n) {
    require_no_nul(pool, "the thread pool name");
    Use use(*state_);
    check(ln_set_max_threads(state_->handle, pool.c_str(), n), "set_max_threads");
  }
  void thread_pool_setschedparam(const std::string& pool, int policy, int priority, unsigned int affinity) {
    require_no_nul(pool, "the thread pool name");
    Use use(*state_);
    check(ln_thread_pool_setschedparam(state_->handle, pool.c_str(), policy, priority, affinity),
          "thread_pool_setschedparam");
  }
  void set_float_parameter(const std::string& name, float value) {
    require_no_nul(name, "the parameter name");
    Use use(*state_);
    check(ln_client_set_float_parameter(state_->handle, name.c_str(), value), "set_float_parameter");
  }
  void register_as_service_logger(const std::string& service, const std::string& patterns) {
    require_no_nul(service, "the service name");
    require_no_nul(patterns, "the service name patterns");
    Use use(*state_);
    check(ln_register_as_service_logger(state_->handle, service.c_str(), patterns.c_str()),
          "register_as_service_logger");
  }
  void set_thread_safe(bool enable) {
    Use use(*state_);
    check(ln_client_set_thread_safe(state_->handle, enable ? 1 : 0), "set_thread_safe");
  }

  void set_availability_handler(bool service, const std::string& name, nb::object callback) {
    require_no_nul(name, service ? "the service name" : "the topic name");
    Use use(*state_);
    AvailabilityHandler* handler = callback.is_none() ? nullptr : new AvailabilityHandler{callback};
    int ret;
    {
      nb::gil_scoped_release release;  // the first call happens right away, in another thread
      ret = service ? ln_set_service_availability_handler(state_->handle, name.c_str(),
                                                          handler ? availability_trampoline : nullptr, handler)
                    : ln_set_publisher_availability_handler(state_->handle, name.c_str(),
                                                            handler ? availability_trampoline : nullptr, handler);
    }
    if (ret < 0) {
      delete handler;
      fail(ret, "set availability handler", state_->handle);
    }
    const std::string key = (service ? "s:" : "t:") + name;
    auto old = named_handlers_.find(key);
    if (old != named_handlers_.end()) {
      handlers_.erase(old->second);
      delete old->second;
      named_handlers_.erase(old);
    }
    if (handler) {
      handlers_.insert(handler);
      named_handlers_[key] = handler;
    }
  }

  void check(int ret, const std::string& what) {
    if (ret < 0) fail(ret, what, state_->handle);
  }
  // As check() for code running without the GIL: only builds the Failure.
  void check_nogil(int ret, const std::string& what) {
    if (ret < 0) fail(ret, what, state_->handle);
  }

 private:
  StatePtr state_;
  std::set<AvailabilityHandler*> handlers_;
  std::map<std::string, AvailabilityHandler*> named_handlers_;
};

}  // namespace lnpy
