// links_and_nodes._ln: the thin native layer of the Python package over
// libln's C API (ln/ln.h) and the md model. Everything friendly lives in the
// pure-Python package; this file only moves bytes and handles, releases the
// GIL while waiting and turns LN error codes into LNError.
//
// Waiting calls (read, multi-waiter wait, service calls, group handling) run
// in slices of at most kSlice seconds with the GIL released and check for
// Python signals between slices, so Ctrl-C interrupts them.
#include <nanobind/nanobind.h>
#include <nanobind/stl/map.h>
#include <nanobind/stl/optional.h>
#include <nanobind/stl/string.h>
#include <nanobind/stl/vector.h>

#include <fcntl.h>
#include <signal.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <mutex>
#include <set>
#include <thread>

#include "introspection.hpp"
#include "ln/ln.h"
#include "loggers.hpp"
#include "model.hpp"
#include "parameters.hpp"

namespace nb = nanobind;
using namespace nb::literals;

namespace lnpy {
namespace {

constexpr double kSlice = 0.05;
PyObject* LNError = nullptr;
unsigned long main_thread_ident = 0;  // only the main thread runs signal handlers

// ----------------------------------------------------------------- errors

struct Failure {
  int code;  // LNE_* (positive)
  std::string message;
  int user_code = 0;  // with LNE_USER_DEFINED_ERROR: the provider's own error code
};

[[noreturn]] void fail(int ret, const std::string& what, ln_client clnt = nullptr) {
  std::string message = what + ": " + ln_format_error(ret);
  if (clnt != nullptr) {
    const char* detail = ln_get_error_message(clnt);
    if (detail != nullptr && *detail != '\0') message += ": " + std::string(detail);
  }
  throw Failure{ret < 0 ? -ret : ret, message};
}

// LN 2.9's Python raises plain Exceptions whose text names the error
// ("...: LNE_SVC_TIMEOUT - ..."), so programs match that text: every
// LNError's text names its LNE_* code too.
std::string naming_the_code(std::string message, int code) {
  if (message.find("LNE_") != std::string::npos) return message;
  const std::string formatted = ln_format_error(-code);
  return message + " (" + formatted.substr(0, formatted.find(' ')) + ")";
}

// Names and texts go to the C API as C strings, where a NUL byte would cut
// them: "a.b\0x" would silently publish "a.b".
void require_no_nul(const std::string& value, const char* what) {
  if (value.find('\0') != std::string::npos)
    throw nb::value_error((std::string(what) + " must not contain NUL bytes: " +
                           std::string(nb::repr(nb::str(value.data(), value.size())).c_str()))
                              .c_str());
}
void require_no_nul(const std::optional<std::string>& value, const char* what) {
  if (value) require_no_nul(*value, what);
}

[[noreturn]] void throw_closed() { throw Failure{LNE_CLIENT_NOT_INITIALIZED, "the client was closed"}; }

double now() { return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count(); }

// Runs step(slice_timeout) until it returns non-zero or `timeout` passed
// (timeout < 0: no limit; 0: one poll with the GIL held). Between slices
// pending signals run their Python handlers; an exception they raise
// propagates (after `on_interrupt`).
struct ClientState;
bool is_closed(const ClientState* state);

struct NoInterruptAction {
  void operator()() const {}
};

template <class Step, class OnInterrupt = NoInterruptAction>
int wait_in_slices(double timeout, const ClientState* state, Step step, OnInterrupt on_interrupt = {}) {
  if (timeout == 0) return step(0.0);
  // The clock is read only to end a finite wait: most waits end in their
  // first slice, and every read costs on the latency path of a round trip.
  const bool forever = timeout < 0;
  const double deadline = forever ? INFINITY : now() + timeout;
  double slice = forever ? kSlice : std::min(kSlice, timeout);
  for (;;) {
    if (state != nullptr && is_closed(state)) {
      on_interrupt();
      throw_closed();
    }
    int ret;
    {
      nb::gil_scoped_release release;
      ret = step(slice);
    }
    if (ret != 0) return ret;
    if (PyErr_CheckSignals() != 0) {
      on_interrupt();
      throw nb::python_error();
    }
    if (!forever) {
      const double remaining = deadline - now();
      if (remaining <= 0) return 0;
      slice = std::min(kSlice, remaining);
    }
  }
}

// LN's blocking_or_timeout argument in seconds: True or None wait without
// limit (-1), False polls (0), a number waits that long (<= 0: polls).
double timeout_argument(nb::handle value) {
  if (value.is_none() || value.ptr() == Py_True) return -1.0;
  if (value.ptr() == Py_False) return 0.0;
  double timeout;
  if (PyFloat_CheckExact(value.ptr())) {
    timeout = PyFloat_AS_DOUBLE(value.ptr());
  } else {
    PyObject* number = PyNumber_Float(value.ptr());  // what float() accepts
    if (number == nullptr) {
      PyErr_Clear();
      throw nb::type_error(("blocking_or_timeout must be True, False or a timeout in seconds, not " +
                            std::string(nb::repr(value).c_str()))
                               .c_str());
    }
    timeout = PyFloat_AS_DOUBLE(number);
    Py_DECREF(number);
  }
  return timeout > 0 ? timeout : 0.0;
}

// A Python buffer held for the duration of a call.
struct Buffer {
  Py_buffer view{};
  Buffer(nb::handle object, bool writable, const char* what) {
    if (PyObject_GetBuffer(object.ptr(), &view, writable ? PyBUF_WRITABLE : PyBUF_SIMPLE) != 0) {
      PyErr_Clear();
      throw nb::type_error(
          (std::string(what) + " must be a " + (writable ? "writable " : "") + "bytes-like object").c_str());
    }
  }
  ~Buffer() { PyBuffer_Release(&view); }
  char* data() const { return static_cast<char*>(view.buf); }
  std::size_t size() const { return static_cast<std::size_t>(view.len); }
};

// ---------------------------------------------------------------- client

// Shared by a client and every handle made from it: handles check `handle`
// before each use, and close() waits until no call is inside the library.
struct ClientState {
  std::atomic<ln_client> handle{nullptr};
  std::atomic<int> busy{0};
  std::atomic<int> loans{0};              // borrowed packets not yet released
  std::atomic<std::uint64_t> handled{0};  // requests given to Python handlers
  std::mutex mutex;
  std::set<ln_inport> inports;
  std::set<std::string> groups_waiting;
};

// Marks a call in progress on a client; throws if the client is closed.
struct Use {
  ClientState& state;
  explicit Use(ClientState& s) : state(s) {
    state.busy.fetch_add(1);
    if (state.handle == nullptr) {
      state.busy.fetch_sub(1);
      throw Failure{LNE_CLIENT_NOT_INITIALIZED, "the client is closed"};
    }
  }
  ~Use() { state.busy.fetch_sub(1); }
};

using StatePtr = std::shared_ptr<ClientState>;

bool is_closed(const ClientState* state) { return state->handle.load() == nullptr; }

std::optional<std::string> take_string(char* text) {
  if (text == nullptr) return std::nullopt;
  std::string out(text);
  std::free(text);
  return out;
}

struct AvailabilityHandler {
  nb::object callback;
};

void availability_trampoline(ln_client, const char* name, int available, void* user) {
  if (_Py_IsFinalizing()) return;
  nb::gil_scoped_acquire acquire;
  try {
    static_cast<AvailabilityHandler*>(user)->callback(std::string(name), available != 0);
  } catch (nb::python_error& error) {
    error.discard_as_unraisable("links_and_nodes availability handler");
  }
}

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
    int ret;
    {
      nb::gil_scoped_release release;
      ret = ln_ping(state_->handle, timeout, &rtt);
    }
    check(ret, "ping");
    return rtt;
  }

  nb::tuple get_message_definition(const std::string& name) {
    require_no_nul(name, "the message definition name");
    Use use(*state_);
    char *md = nullptr, *hash = nullptr, *flat = nullptr;
    unsigned int size = 0;
    int ret;
    {
      nb::gil_scoped_release release;
      ret = ln_get_message_definition_v21(state_->handle, name.c_str(), &md, &size, &hash, &flat);
    }
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
    int ret;
    {
      nb::gil_scoped_release release;
      ret = ln_get_message_definition_for_topic_v17(state_->handle, topic.c_str(), &md_name, &md, &size, &hash);
    }
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
    int ret;
    {
      nb::gil_scoped_release release;
      ret = ln_get_service_signature(state_->handle, interface.c_str(), &definition, &signature);
    }
    check(ret, "get_service_signature('" + interface + "')");
    auto d = take_string(definition);
    auto s = take_string(signature);
    return nb::make_tuple(d.value_or(""), s.value_or(""));
  }

  nb::tuple get_service_signature_for_service(const std::string& service) {
    require_no_nul(service, "the service name");
    Use use(*state_);
    char *interface = nullptr, *definition = nullptr, *signature = nullptr;
    int ret;
    {
      nb::gil_scoped_release release;
      ret = ln_get_service_signature_for_service(state_->handle, service.c_str(), &interface, &definition, &signature);
    }
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
    int ret;
    {
      nb::gil_scoped_release release;
      ret = ln_needs_provider(state_->handle, name.c_str(), timeout);
    }
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
      int ret;
      {
        nb::gil_scoped_release release;
        ret = ln_wait_and_handle_service_group_requests(state_->handle, group_name, slice);
      }
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

// ------------------------------------------------------------------ topics

class OutPort {
 public:
  OutPort(Client& client, const std::string& topic, const std::string& md_name, unsigned int buffers)
      : state_(client.state()) {
    require_no_nul(topic, "the topic name");
    require_no_nul(md_name, "the message definition name");
    Use use(*state_);
    int ret;
    {
      nb::gil_scoped_release release;
      ret = ln_publish_with_buffers(state_->handle, topic.c_str(), md_name.c_str(), buffers, &port_);
    }
    if (ret < 0) fail(ret, "cannot publish '" + topic + "'", state_->handle);
    size_ = static_cast<unsigned int>(ln_get_message_size(port_));
    const char* hash = ln_get_msg_def_hash(port_);
    hash_ = hash ? hash : "";
  }

  void write(nb::handle data, std::optional<double> timestamp) {
    ln_outport port = get();
    Buffer buffer(data, false, "packet");
    if (buffer.size() < size_) throw nb::value_error("packet buffer is smaller than the message size");
    double ts = timestamp.value_or(0);
    const int ret = ln_write(port, buffer.data(), size_, timestamp ? &ts : nullptr);
    if (ret < 0) fail(ret, "write", state_->handle);
  }

  // The number of subscribers, as LN 2.9 returns it.
  int has_subscriber() {
    Use use(*state_);
    const int ret = ln_has_subscriber(get());
    if (ret < 0) fail(ret, "has_subscriber", state_->handle);
    return ret;
  }

  void unpublish() {
    if (port_ == nullptr || state_->handle == nullptr) {
      port_ = nullptr;
      return;
    }
    Use use(*state_);
    nb::gil_scoped_release release;
    ln_unpublish(&port_);
    port_ = nullptr;
  }

  unsigned int size() const { return size_; }
  const std::string& hash() const { return hash_; }

 private:
  ln_outport get() {
    if (port_ == nullptr || state_->handle == nullptr) throw Failure{LNE_INVALID_PORT_OBJECT, "the port is closed"};
    return port_;
  }
  StatePtr state_;
  ln_outport port_ = nullptr;
  unsigned int size_ = 0;
  std::string hash_;
};

class InPort;

// A packet lent by ln_read_borrow(): a read-only buffer until released.
// While memoryviews or arrays made from it exist, release() only marks it
// and the loan ends with the last of them, so Python never sees memory that
// the publisher reuses; unsubscribing or closing the client meanwhile fails.
class Loan {
 public:
  Loan(nb::object port_object, InPort* port, const void* data, unsigned int size)
      : port_object_(std::move(port_object)), port_(port), data_(data), size_(size) {}
  ~Loan() { finish(); }
  void release() {
    released_ = true;
    if (exports_ == 0) finish();
  }
  bool released() const { return released_; }
  int exports() const { return exports_; }
  void finish();
  static int getbuffer(PyObject* self, Py_buffer* view, int flags);
  static void releasebuffer(PyObject* self, Py_buffer* view);

 private:
  nb::object port_object_;  // keeps the port (and its client state) alive
  InPort* port_;
  const void* data_;
  unsigned int size_;
  int exports_ = 0;
  bool released_ = false;
  bool finished_ = false;
};

class InPort {
 public:
  InPort(Client& client, const std::string& topic, const std::string& md_name, double rate, unsigned int buffers,
         bool reliable)
      : state_(client.state()) {
    require_no_nul(topic, "the topic name");
    require_no_nul(md_name, "the message definition name");
    Use use(*state_);
    int ret;
    {
      nb::gil_scoped_release release;
      ret = ln_subscribe_with_buffers(state_->handle, topic.c_str(), md_name.c_str(), &port_, rate, reliable ? 1 : 0,
                                      buffers);
    }
    if (ret < 0) fail(ret, "cannot subscribe '" + topic + "'", state_->handle);
    size_ = static_cast<unsigned int>(ln_get_message_size(port_));
    const char* hash = ln_get_msg_def_hash(port_);
    hash_ = hash ? hash : "";
    std::lock_guard<std::mutex> lock(state_->mutex);
    state_->inports.insert(port_);
  }

  // Copies the next packet into `data`; false if none came within
  // `blocking_or_timeout` (see timeout_argument).
  bool read(nb::handle data, nb::handle blocking_or_timeout) {
    const double timeout = timeout_argument(blocking_or_timeout);
    Use use(*state_);
    ln_inport port = get();
    Buffer buffer(data, true, "packet");
    if (buffer.size() < size_) throw nb::value_error("packet buffer is smaller than the message size");
    ln_sample_info info{};
    const int ret =
        read_packet(timeout, [&](double slice) { return ln_read_with_info(port, buffer.data(), size_, &info, slice); });
    if (ret < 0) fail(ret, "read", state_->handle);
    if (ret == 0) return false;
    timestamp = info.timestamp;
    sequence = info.sequence;
    lost = info.lost;
    return true;
  }

  // The next packet in place (a Loan), or None.
  nb::object borrow(nb::handle self, nb::handle blocking_or_timeout) {
    const double timeout = timeout_argument(blocking_or_timeout);
    Use use(*state_);
    ln_inport port = get();
    if (loan_ != nullptr)
      throw Failure{LNE_INVALID_PARAMETER, loan_->released()
                                               ? "the previously borrowed packet of this port is still in use by "
                                                 "memoryviews or arrays"
                                               : "the previously borrowed packet of this port is not released yet"};
    const void* packet = nullptr;
    unsigned int size = 0;
    ln_sample_info info{};
    const int ret =
        read_packet(timeout, [&](double slice) { return ln_read_borrow(port, &packet, &size, &info, slice); });
    if (ret < 0) fail(ret, "borrow", state_->handle);
    if (ret == 0) return nb::none();
    timestamp = info.timestamp;
    sequence = info.sequence;
    lost = info.lost;
    loan_ = new Loan(nb::borrow(self), this, packet, size);
    state_->loans.fetch_add(1);
    return nb::cast(loan_, nb::rv_policy::take_ownership);
  }

  void end_loan() {
    if (loan_ == nullptr) return;
    loan_ = nullptr;
    state_->loans.fetch_sub(1);
    if (port_ != nullptr && state_->handle != nullptr) ln_read_release(port_);
  }

  bool has_publisher() {
    Use use(*state_);
    const int ret = ln_has_publisher(get());
    if (ret < 0) fail(ret, "has_publisher", state_->handle);
    return ret > 0;
  }

  void unblock() {
    Use use(*state_);
    ln_unblock(get());
  }

  void unsubscribe() {
    if (port_ == nullptr || state_->handle == nullptr) {
      port_ = nullptr;
      return;
    }
    if (loan_ != nullptr) {
      if (loan_->exports() > 0)
        throw Failure{LNE_INVALID_PARAMETER, "a borrowed packet of this port is still in use by memoryviews or arrays"};
      loan_->finish();
    }
    Use use(*state_);
    {
      std::lock_guard<std::mutex> lock(state_->mutex);
      state_->inports.erase(port_);
    }
    nb::gil_scoped_release release;
    ln_unsubscribe(&port_);
    port_ = nullptr;
  }

  unsigned int size() const { return size_; }
  const std::string& hash() const { return hash_; }
  ln_inport raw() { return get(); }

  double timestamp = 0;
  std::uint64_t sequence = 0;
  std::uint64_t lost = 0;

 private:
  ln_inport get() {
    if (port_ == nullptr || state_->handle == nullptr) throw Failure{LNE_INVALID_PORT_OBJECT, "the port is closed"};
    return port_;
  }

  // Runs `attempt(slice_timeout)` (a libln read) as wait_in_slices does, but
  // takes a packet that is there already with the GIL held: releasing and
  // retaking the GIL costs about as much as the read itself. Not while
  // another thread reads this port: libln lets one read at a time in and
  // holds the others while it waits, which must not happen with the GIL held.
  template <class Attempt>
  int read_packet(double timeout, Attempt attempt) {
    if (reads_waiting_ == 0) {
      const int ret = attempt(0.0);
      if (ret != 0 || timeout == 0) return ret;
    }
    ++reads_waiting_;  // changed only with the GIL held
    struct Leave {
      int& count;
      ~Leave() { --count; }
    } leave{reads_waiting_};
    if (timeout == 0) {
      nb::gil_scoped_release release;
      return attempt(0.0);
    }
    return wait_in_slices(timeout, state_.get(), attempt);
  }

  StatePtr state_;
  ln_inport port_ = nullptr;
  unsigned int size_ = 0;
  std::string hash_;
  Loan* loan_ = nullptr;
  int reads_waiting_ = 0;  // reads of this port in other threads, waiting with the GIL released
};

void Loan::finish() {
  if (finished_) return;
  finished_ = true;
  released_ = true;
  port_->end_loan();
}

int Loan::getbuffer(PyObject* self, Py_buffer* view, int flags) {
  Loan* loan = nb::inst_ptr<Loan>(self);
  view->obj = nullptr;
  if (loan->released_) {
    PyErr_SetString(PyExc_BufferError, "the borrowed packet was released");
    return -1;
  }
  if (flags & PyBUF_WRITABLE) {
    PyErr_SetString(PyExc_BufferError, "a borrowed packet is read-only");
    return -1;
  }
  if (PyBuffer_FillInfo(view, self, const_cast<void*>(loan->data_), loan->size_, 1, flags) != 0) return -1;
  loan->exports_++;
  return 0;
}

void Loan::releasebuffer(PyObject* self, Py_buffer*) {
  Loan* loan = nb::inst_ptr<Loan>(self);
  if (--loan->exports_ == 0 && loan->released_) loan->finish();
}

PyType_Slot loan_slots[] = {{Py_bf_getbuffer, reinterpret_cast<void*>(Loan::getbuffer)},
                            {Py_bf_releasebuffer, reinterpret_cast<void*>(Loan::releasebuffer)},
                            {0, nullptr}};

// ------------------------------------------------------------ multi-waiter

class MultiWaiter {
 public:
  explicit MultiWaiter(Client& client) : state_(client.state()) {
    Use use(*state_);
    const int ret = ln_multi_waiter_init(state_->handle, &waiter_);
    if (ret < 0) fail(ret, "get_multi_waiter", state_->handle);
  }
  void add_port(InPort& port) {
    Use use(*state_);
    check(ln_multi_waiter_add_port(get(), port.raw()), "add_port");
  }
  void remove_port(InPort& port) {
    Use use(*state_);
    check(ln_multi_waiter_remove_port(get(), port.raw()), "remove_port");
  }
  bool wait(double timeout) {
    Use use(*state_);
    ln_multi_waiter waiter = get();
    const int ret =
        wait_in_slices(timeout, state_.get(), [&](double slice) { return ln_multi_waiter_wait(waiter, slice); });
    check(ret, "wait");
    return ret > 0;
  }
  bool can_read(InPort& port) {
    Use use(*state_);
    const int ret = ln_multi_waiter_can_read(get(), port.raw());
    check(ret, "can_read");
    return ret > 0;
  }
  int start_pipe_notifier_thread() {
    Use use(*state_);
    ln_pipe_fd_t fd = -1;
    check(ln_multi_waiter_start_pipe_notifier_thread(get(), &fd), "start_pipe_notifier_thread");
    return fd;
  }
  void ack_pipe_notification() {
    Use use(*state_);
    check(ln_multi_waiter_ack_pipe_notification(get()), "ack_pipe_notification");
  }

 private:
  void check(int ret, const std::string& what) {
    if (ret < 0) fail(ret, "multi_waiter." + what, state_->handle);
  }
  ln_multi_waiter get() {
    if (waiter_ == nullptr || state_->handle == nullptr)
      throw Failure{LNE_CLIENT_NOT_INITIALIZED, "the client is closed"};
    return waiter_;
  }
  StatePtr state_;
  ln_multi_waiter waiter_ = nullptr;
};

// ------------------------------------------------------- call interrupter

// Blocking service calls in the main thread run as one fast library call
// (the asynchronous API costs a thread hand-off per call). To keep Ctrl-C
// working, SIGINT is chained: our handler wakes a watcher thread through a
// pipe, which aborts the running call, and then runs the previously
// installed handler (Python's), so KeyboardInterrupt follows as usual. If
// Python code installs another SIGINT disposition later, the next call puts
// the chain back in front of it; with SIG_IGN calls are not aborted.
class CallInterrupter {
 public:
  // Marks `svc` as the main thread's running call (nullptr: none).
  static void set_current(ln_service svc) {
    std::lock_guard<std::mutex> lock(mutex_);
    current_ = svc;
  }
  // Installs the chain (again) if SIGINT's handler is not ours.
  static bool ensure_installed() {
    struct sigaction now {};
    if (sigaction(SIGINT, nullptr, &now) != 0) return false;
    if ((now.sa_flags & SA_SIGINFO) && now.sa_sigaction == &CallInterrupter::handler) return true;
    if (pipe_w_ < 0) {
      int fds[2];
      if (pipe2(fds, O_CLOEXEC) != 0) return false;
      pipe_r_ = fds[0];
      pipe_w_ = fds[1];
      std::thread(&CallInterrupter::watch).detach();
    }
    previous_ = now;
    struct sigaction ours {};
    ours.sa_sigaction = &CallInterrupter::handler;
    ours.sa_mask = now.sa_mask;
    ours.sa_flags = SA_SIGINFO | (now.sa_flags & (SA_ONSTACK | SA_RESTART));
    return sigaction(SIGINT, &ours, nullptr) == 0;
  }

 private:
  static void handler(int sig, siginfo_t* info, void* context) {
    const int saved_errno = errno;
    const struct sigaction previous = previous_;
    if (previous.sa_handler != SIG_IGN || (previous.sa_flags & SA_SIGINFO)) {
      char byte = 1;
      ssize_t ignored = write(pipe_w_, &byte, 1);
      (void)ignored;
    }
    if (previous.sa_flags & SA_SIGINFO) {
      previous.sa_sigaction(sig, info, context);
    } else if (previous.sa_handler == SIG_DFL) {
      signal(sig, SIG_DFL);
      raise(sig);
    } else if (previous.sa_handler != SIG_IGN) {
      previous.sa_handler(sig);
    }
    errno = saved_errno;
  }
  static void watch() {
    char byte;
    while (read(pipe_r_, &byte, 1) >= 0 || errno == EINTR) {
      std::lock_guard<std::mutex> lock(mutex_);
      if (current_ != nullptr) ln_service_call_abort(current_);
    }
  }
  static inline std::mutex mutex_;
  static inline ln_service current_ = nullptr;
  static inline int pipe_r_ = -1;
  static inline int pipe_w_ = -1;
  static inline struct sigaction previous_ {};
};

// ---------------------------------------------------------------- services

nb::bytes response_bytes(const char* data, uint32_t len) { return nb::bytes(data, len); }

class Request;

// A request being handled by a provider; invalid once answered and the
// handler returned (unless the handler deferred it).
class Request {
 public:
  Request(StatePtr state, ln_service_request request) : state_(std::move(state)), request_(request) {}

  nb::bytes data() {
    char* buffer = nullptr;
    uint64_t len = 0;
    check(ln_service_request_get_request_data(get(), &buffer, &len), "request data");
    return nb::bytes(buffer, static_cast<size_t>(len));
  }
  void respond(nb::handle flat) {
    ln_service_request request = get();
    Buffer buffer(flat, false, "response");
    struct iovec iov {
      buffer.data(), buffer.size()
    };
    int ret;
    if (buffer.size() < 65536) {
      ret = ln_service_request_respondv(request, &iov, 1);  // fits the socket buffer: does not block
    } else {
      nb::gil_scoped_release release;
      ret = ln_service_request_respondv(request, &iov, 1);
    }
    check(ret, "respond");
    responded = true;
  }
  void respond_error(int code, const std::string& message) {
    require_no_nul(message, "the error message");
    check(ln_service_request_respond_error(get(), code, message.c_str()), "respond_error");
    responded = true;
  }
  bool is_aborted() {
    const int ret = ln_service_request_is_aborted(get());
    check(ret, "is_aborted");
    return ret > 0;
  }
  void invalidate() { request_ = nullptr; }
  bool valid() const { return request_ != nullptr; }

  bool responded = false;
  bool deferred = false;

 private:
  void check(int ret, const std::string& what) {
    if (ret < 0) fail(ret, what);
  }
  ln_service_request get() {
    if (request_ == nullptr || state_->handle == nullptr)
      throw Failure{LNE_SVC_REQ_NOT_RUNNING, "the service request was already answered"};
    return request_;
  }
  StatePtr state_;
  ln_service_request request_;
};

class Service {
 public:
  Service(Client& client, const std::string& name, const std::string& interface, const std::string& signature)
      : state_(client.state()), name_(name) {
    require_no_nul(name, "the service name");
    require_no_nul(interface, "the service interface");
    require_no_nul(signature, "the service signature");
    Use use(*state_);
    int ret;
    {
      nb::gil_scoped_release release;
      ret = ln_service_init(state_->handle, &svc_, name.c_str(), interface.c_str(), signature.c_str());
    }
    if (ret < 0) fail(ret, "cannot create service '" + name + "'", state_->handle);
  }

  // Blocking call with the flat request. Returns the flat response, or
  // None when it was copied into `into` (a writable buffer of exactly the
  // response's size: the fixed-size case).
  nb::object call(nb::handle flat, double timeout, nb::handle into) {
    Use use(*state_);
    ln_service svc = get();
    Buffer buffer(flat, false, "request");
    struct iovec iov {
      buffer.data(), buffer.size()
    };
    uint8_t element_len = 1;
    char* response = nullptr;
    uint32_t response_len = 0;
    uint8_t need_swap = 0;
    int ret;
    const bool watched =
        interruptible_ && PyThread_get_thread_ident() == main_thread_ident && CallInterrupter::ensure_installed();
    if (watched) {
      CallInterrupter::set_current(svc);
      if (PyErr_CheckSignals() != 0) {  // a Ctrl-C that came just before
        CallInterrupter::set_current(nullptr);
        throw nb::python_error();
      }
    }
    {
      nb::gil_scoped_release release;
      ret = ln_service_callv_with_timeout(svc, &iov, 1, &element_len, &response, &response_len, &need_swap,
                                          timeout > 0 ? timeout : 0);
    }
    if (watched) {
      CallInterrupter::set_current(nullptr);
      if (ret != 0 && PyErr_CheckSignals() != 0) throw nb::python_error();
    }
    if (ret != 0) fail_call(ret, ln_get_error_message(state_->handle));
    if (!into.is_none()) {
      Buffer target(into, true, "response buffer");
      if (target.size() == response_len) {
        std::memcpy(target.data(), response, response_len);
        return nb::none();
      }
    }
    return response_bytes(response, response_len);
  }

  // Asynchronous call; poll with poll_async().
  void start_async(nb::handle flat) {
    Use use(*state_);
    ln_service svc = get();
    Buffer buffer(flat, false, "request");
    async_request_.assign(buffer.data(), buffer.size());
    struct iovec iov {
      async_request_.data(), async_request_.size()
    };
    uint8_t element_len = 1;
    const int ret = ln_service_callv_async(svc, &iov, 1, &element_len, &async_);
    if (ret < 0) fail(ret, "call_async of service '" + name_ + "'", state_->handle);
  }

  // None while running (waits up to `timeout`), else the flat response.
  nb::object poll_async(double timeout) {
    Use use(*state_);
    if (async_ == nullptr) throw Failure{LNE_SVC_REQ_NOT_RUNNING, "no asynchronous call is running"};
    ln_service_request request = async_;
    int retval = 0;
    const int done = wait_in_slices(timeout, state_.get(),
                                    [&](double slice) { return ln_service_request_wait(request, slice, &retval); });
    if (done < 0) {
      async_ = nullptr;
      fail(done, "call_async of service '" + name_ + "'", state_->handle);
    }
    if (done == 0) return nb::none();
    async_ = nullptr;
    if (retval != 0) fail_call(retval, ln_service_request_get_error_message(request));
    char* response = nullptr;
    uint32_t response_len = 0;
    const int ret = ln_service_callv_async_get_response(get(), &response, &response_len);
    return finish_call(ret, response, response_len);
  }

  // Readable once the asynchronous call finished (for main loops).
  int async_notification_fd() {
    Use use(*state_);
    if (async_ == nullptr) throw Failure{LNE_SVC_REQ_NOT_RUNNING, "no asynchronous call is running"};
    int fd = -1;
    const int ret = ln_service_request_get_finished_notification_fd(async_, &fd);
    if (ret < 0) fail(ret, "get_finished_notification_fd", state_->handle);
    return fd;
  }

  void abort_async() {
    Use use(*state_);
    if (async_ == nullptr) throw Failure{LNE_SVC_REQ_NOT_RUNNING, "no asynchronous call is running"};
    ln_service_request_abort(async_);
    async_ = nullptr;
  }

  void abort() {
    Use use(*state_);
    ln_service_call_abort(get());
    if (async_) ln_service_request_abort(async_);
  }

  ~Service() {
    try {
      release();
    } catch (...) {
    }
  }

  // handler(request, prefilled): `prefilled` tells that the request was
  // copied into `request_buffer` already (fixed-size requests).
  void set_handler(nb::object handler, nb::object request_buffer) {
    Use use(*state_);
    handler_ = std::move(handler);
    request_buffer_ = std::move(request_buffer);
    const int ret = ln_service_provider_set_handler(get(), &Service::trampoline, this);
    if (ret < 0) fail(ret, "set_handler", state_->handle);
  }

  void register_in_group(std::optional<std::string> group) {
    require_no_nul(group, "the service group name");
    Use use(*state_);
    int ret;
    ln_service svc = get();
    {
      nb::gil_scoped_release release;
      ret = ln_service_provider_register_in_group(state_->handle, svc, group ? group->c_str() : nullptr);
    }
    if (ret < 0) fail(ret, "cannot register service '" + name_ + "'", state_->handle);
  }

  int get_fd() {
    Use use(*state_);
    const int ret = ln_service_provider_get_fd(get());
    if (ret < 0) fail(ret, "get_fd", state_->handle);
    return ret;
  }

  void release() {
    if (svc_ == nullptr || state_->handle == nullptr) {
      svc_ = nullptr;
      return;
    }
    Use use(*state_);
    {
      nb::gil_scoped_release release;
      ln_service_deinit(&svc_);
    }
    svc_ = nullptr;
    handler_ = nb::object();
    request_buffer_ = nb::object();
  }

  static void set_interruptible(bool on) { interruptible_ = on; }
  static bool interruptible() { return interruptible_; }

 private:
  static int trampoline(ln_client, ln_service_request request, void* user) {
    if (_Py_IsFinalizing()) return -LNE_SVC_HANDLER_EXC;
    Service* self = static_cast<Service*>(user);
    self->state_->handled.fetch_add(1);
    nb::gil_scoped_acquire acquire;
    auto* wrapped = new Request(self->state_, request);
    nb::object py_request = nb::cast(wrapped, nb::rv_policy::take_ownership);
    int ret = -LNE_SVC_HANDLER_EXC;
    try {
      bool prefilled = false;
      if (!self->request_buffer_.is_none()) {
        char* data = nullptr;
        uint64_t len = 0;
        Buffer target(self->request_buffer_, true, "request buffer");
        if (ln_service_request_get_request_data(request, &data, &len) == 0 && len == target.size()) {
          std::memcpy(target.data(), data, len);
          prefilled = true;
        }
      }
      ret = nb::cast<int>(self->handler_(py_request, prefilled));
    } catch (nb::python_error& error) {
      // The Python layer catches handler exceptions; reaching here is a bug
      // in it or a signal: fail the call and let Python report it.
      error.discard_as_unraisable("links_and_nodes service handler");
      if (!wrapped->responded) {
        ln_service_request_respond_error(request, -LNE_SVC_HANDLER_EXC, "exception in the Python service handler");
        ret = 0;
      }
    } catch (std::exception&) {
      ret = -LNE_SVC_HANDLER_EXC;
    }
    if (ret != -LNE_SVC_RESP_LATER) wrapped->invalidate();
    return ret;
  }

  nb::bytes finish_call(int ret, char* response, uint32_t response_len) {
    if (ret != 0) fail_call(ret, ln_get_error_message(state_->handle));
    return response_bytes(response, response_len);
  }

  [[noreturn]] void fail_call(int ret, const char* detail) {
    std::string message = "call of service '" + name_ + "' failed: ";
    message += ret > 0 ? "provider returned error " + std::to_string(ret) : std::string(ln_format_error(ret));
    if (detail != nullptr && *detail != '\0') message += ": " + std::string(detail);
    if (ret > 0) throw Failure{LNE_USER_DEFINED_ERROR, message, ret};
    throw Failure{-ret, message};
  }

  ln_service get() {
    if (svc_ == nullptr || state_->handle == nullptr)
      throw Failure{LNE_CLIENT_NOT_INITIALIZED, "the service was released"};
    return svc_;
  }

  StatePtr state_;
  std::string name_;
  ln_service svc_ = nullptr;
  nb::object handler_;
  nb::object request_buffer_;
  ln_service_request async_ = nullptr;
  std::string async_request_;
  static inline bool interruptible_ = true;
};

// ---------------------------------------------------------------- events

// An event connection (ln_event_connect_flat): `callback(data)` gets each
// event's flat call data in the thread that handles the client's default
// service group, with the GIL; links_and_nodes/_events.py unpacks it.
class EventConnection {
 public:
  EventConnection(Client& client, const std::string& name, const std::string& connect_signature, nb::bytes connect_flat,
                  nb::object callback)
      : state_(client.state()), callback_(std::move(callback)) {
    Use use(*state_);
    int ret;
    {
      nb::gil_scoped_release release;
      ret = ln_event_connect_flat(state_->handle, &connection_, name.c_str(), connect_signature.c_str(),
                                  const_cast<char*>(connect_flat.c_str()), static_cast<uint32_t>(connect_flat.size()),
                                  &EventConnection::deliver, this);
    }
    if (ret < 0) fail(ret, "connect_to_event('" + name + "')", state_->handle);
  }
  ~EventConnection() { disconnect(); }

  void disconnect() {
    if (connection_ == nullptr) return;
    nb::gil_scoped_release release;  // waits for a running handler, which needs the GIL
    ln_event_connection_deinit(&connection_);
  }
  unsigned int id() const { return connection_ != nullptr ? ln_event_connection_get_id(connection_) : 0; }

 private:
  static void deliver(ln_client, ln_event_call call, void* self) {
    void* data = nullptr;
    uint32_t len = 0;
    if (_Py_IsFinalizing() || ln_event_call_get_buffer(call, &data, &len) != 0) return;
    nb::gil_scoped_acquire acquire;
    try {
      static_cast<EventConnection*>(self)->callback_(nb::bytes(static_cast<const char*>(data), len));
    } catch (nb::python_error& error) {
      error.discard_as_unraisable("links_and_nodes event callback");
    }
  }

  StatePtr state_;
  ln_event_connection connection_ = nullptr;
  nb::object callback_;
};

}  // namespace
}  // namespace lnpy

using namespace lnpy;

NB_MODULE(_ln, m) {
  m.doc() = "Native layer of links_and_nodes on ln_core's libln (thin; use the links_and_nodes package).";

  LNError = PyErr_NewExceptionWithDoc("links_and_nodes._ln.LNError",
                                      "An LN operation failed. args: (message, code, user_code): code is the LNE_* "
                                      "number; user_code the provider's own error code (LNE_USER_DEFINED_ERROR).",
                                      PyExc_Exception, nullptr);
  m.attr("LNError") = nb::handle(LNError);
  nb::register_exception_translator([](const std::exception_ptr& p, void*) {
    try {
      std::rethrow_exception(p);
    } catch (const Failure& f) {
      PyObject* args = Py_BuildValue("(sii)", naming_the_code(f.message, f.code).c_str(), f.code, f.user_code);
      PyErr_SetObject(LNError, args);
      Py_XDECREF(args);
    } catch (const ln::md::Error& e) {
      PyObject* args = Py_BuildValue("(sii)", naming_the_code(e.what(), LNE_INVALID_PARAMETER).c_str(),
                                     static_cast<int>(LNE_INVALID_PARAMETER), 0);
      PyErr_SetObject(LNError, args);
      Py_XDECREF(args);
    }
  });

  main_thread_ident = nb::cast<unsigned long>(nb::module_::import_("threading").attr("main_thread")().attr("ident"));
  m.attr("LN_LIBRARY_VERSION") = LN_LIBRARY_VERSION;
  m.attr("RATE_AS_PUBLISHED") = RATE_AS_PUBLISHED;
  m.attr("RATE_ON_REQUEST_LAST") = RATE_ON_REQUEST_LAST;
  m.def("format_error", [](int code) { return std::string(ln_format_error(code)); });
  m.def("get_time", &ln_get_time);
  m.def("get_monotonic_time", &ln_get_monotonic_time);
  m.def("library_version", &ln_get_library_version);
  m.def("set_interruptible_calls", &Service::set_interruptible,
        "Whether Ctrl-C (SIGINT) aborts blocking service calls of the main thread (default True: SIGINT is "
        "chained to abort the call, then Python's handler runs).");
  m.def("interruptible_calls", &Service::interruptible);

  // DSA helpers (LN 2.9's Python has these two): a failure names the file
  // and, for file errors, errno's reason.
  auto check_dsa = [](int ret, const std::string& what) {
    if (ret == -LNE_CHECK_ERRNO) fail(ret, what + " (" + std::strerror(errno) + ")");
    if (ret < 0) fail(ret, what);
  };
  m.def(
      "dsa_dss1_sign_message",
      [check_dsa](const std::string& key_file, nb::handle message) {
        if (!PyBytes_Check(message.ptr()))
          throw nb::value_error("dsa_dss1_sign_message: message is not a bytes object");
        uint8_t* signature = nullptr;
        unsigned int length = 0;
        check_dsa(ln_dsa_dss1_sign_message(
                      key_file.c_str(), reinterpret_cast<const uint8_t*>(PyBytes_AS_STRING(message.ptr())),
                      static_cast<unsigned int>(PyBytes_GET_SIZE(message.ptr())), &signature, &length),
                  "dsa_dss1_sign_message('" + key_file + "')");
        nb::bytes out(reinterpret_cast<const char*>(signature), length);
        std::free(signature);
        return out;
      },
      "pem_private_key_file"_a, "message"_a, "The DSA/SHA-1 signature (DER) of `message` (bytes).");
  m.def(
      "dsa_dss1_generate_key_pair",
      [check_dsa](const std::string& private_file, const std::string& public_file) {
        check_dsa(ln_dsa_dss1_generate_key_pair(private_file.c_str(), public_file.c_str()),
                  "dsa_dss1_generate_key_pair('" + private_file + "', '" + public_file + "')");
      },
      "pem_private_key_file"_a, "openssh_public_key_file"_a,
      "Writes a new DSA key pair: PEM private key (mode 0600), OpenSSH public key.");

  m.def(
      "model_from_sources",
      [](const std::string& name, const std::map<std::string, std::string>& sources) {
        return build_model(name, std::nullopt, [&](const std::string& wanted) -> std::optional<std::string> {
          auto it = sources.find(wanted);
          if (it == sources.end()) return std::nullopt;
          return it->second;
        });
      },
      "name"_a, "sources"_a, "The model of definition `name` built from {name: text}.");
  m.def(
      "model_from_dirs",
      [](const std::string& name, const std::vector<std::string>& dirs) {
        ln::md::Library library(ln::md::SearchPath::exactly(dirs));
        return definition_to_python(library.load(name));
      },
      "name"_a, "dirs"_a, "The model of definition `name` found in `dirs`.");

  nb::class_<Client>(m, "Client")
      .def(nb::init<const std::string&, std::optional<std::string>, std::optional<std::vector<std::string>>>(),
           "name"_a, "manager"_a = nb::none(), "argv"_a = nb::none())
      .def("close", &Client::close)
      .def_prop_ro("closed", &Client::closed)
      // The C API's ln_client, for compiled code in this process that uses the
      // same connection (ln_ros2_bridge's data path); 0 once closed.
      .def_prop_ro("handle", [](const Client& c) { return reinterpret_cast<std::uintptr_t>(c.handle()); })
      .def_prop_ro("name", &Client::name)
      .def("get_remaining_args", &Client::remaining_args)
      .def("ping", &Client::ping, "timeout"_a = -1.0)
      .def("get_message_definition", &Client::get_message_definition)
      .def("get_message_definition_for_topic", &Client::get_message_definition_for_topic)
      .def("describe_message_definition", &Client::describe_message_definition)
      .def("put_message_definition", &Client::put_message_definition)
      .def("locate_member", &Client::locate_member)
      .def("model", &Client::model, "name"_a, "text"_a = nb::none())
      .def("get_service_signature", &Client::get_service_signature)
      .def("get_service_signature_for_service", &Client::get_service_signature_for_service)
      .def("find_services_with_interface", &Client::find_services_with_interface)
      .def("needs_provider", &Client::needs_provider, "name"_a, "timeout"_a = -1.0)
      .def("wait_for_service", &Client::wait_for_service, "name"_a, "timeout"_a = -1.0)
      .def("wait_and_handle_service_group_requests", &Client::wait_and_handle_service_group_requests,
           "group_name"_a = nb::none(), "timeout"_a = -1.0)
      .def("handle_service_group_in_thread_pool", &Client::handle_service_group_in_thread_pool)
      .def("remove_service_group_from_thread_pool", &Client::remove_service_group_from_thread_pool)
      .def("unblock_service_group", &Client::unblock_service_group)
      .def("set_max_threads", &Client::set_max_threads)
      .def("thread_pool_setschedparam", &Client::thread_pool_setschedparam)
      .def("set_thread_safe", &Client::set_thread_safe)
      .def("set_float_parameter", &Client::set_float_parameter)
      .def("register_as_service_logger", &Client::register_as_service_logger)
      .def("set_availability_handler", &Client::set_availability_handler, "service"_a, "name"_a, "callback"_a.none());

  nb::class_<EventConnection>(m, "EventConnection")
      .def(nb::init<Client&, const std::string&, const std::string&, nb::bytes, nb::object>(), "client"_a, "name"_a,
           "connect_signature"_a, "connect_flat"_a, "callback"_a)
      .def("disconnect", &EventConnection::disconnect)
      .def_prop_ro("id", &EventConnection::id);

  nb::class_<OutPort>(m, "OutPort")
      .def(nb::init<Client&, const std::string&, const std::string&, unsigned int>())
      .def("write", &OutPort::write, "data"_a, "timestamp"_a = nb::none())
      .def("has_subscriber", &OutPort::has_subscriber)
      .def("unpublish", &OutPort::unpublish)
      .def_prop_ro("message_size", &OutPort::size)
      .def_prop_ro("msg_def_hash", &OutPort::hash);

  nb::class_<InPort>(m, "InPort")
      .def(nb::init<Client&, const std::string&, const std::string&, double, unsigned int, bool>())
      .def("read", &InPort::read, "data"_a, "blocking_or_timeout"_a.none())
      .def(
          "borrow",
          [](nb::handle self, nb::handle timeout) { return nb::inst_ptr<InPort>(self)->borrow(self, timeout); },
          "blocking_or_timeout"_a.none())
      .def("has_publisher", &InPort::has_publisher)
      .def("unblock", &InPort::unblock)
      .def("unsubscribe", &InPort::unsubscribe)
      .def_prop_ro("message_size", &InPort::size)
      .def_prop_ro("msg_def_hash", &InPort::hash)
      .def_ro("timestamp", &InPort::timestamp)
      .def_ro("sequence", &InPort::sequence)
      .def_ro("lost", &InPort::lost);

  nb::class_<Loan>(m, "Loan", nb::type_slots(loan_slots))
      .def("release", &Loan::release)
      .def_prop_ro("released", &Loan::released);

  nb::class_<MultiWaiter>(m, "MultiWaiter")
      .def(nb::init<Client&>())
      .def("add_port", &MultiWaiter::add_port)
      .def("remove_port", &MultiWaiter::remove_port)
      .def("wait", &MultiWaiter::wait, "timeout"_a = -1.0)
      .def("can_read", &MultiWaiter::can_read)
      .def("start_pipe_notifier_thread", &MultiWaiter::start_pipe_notifier_thread)
      .def("ack_pipe_notification", &MultiWaiter::ack_pipe_notification);

  nb::class_<Request>(m, "Request")
      .def("data", &Request::data)
      .def("respond", &Request::respond)
      .def("respond_error", &Request::respond_error)
      .def("is_aborted", &Request::is_aborted)
      .def_prop_ro("valid", &Request::valid)
      .def_rw("responded", &Request::responded);

  nb::class_<Service>(m, "Service")
      .def(nb::init<Client&, const std::string&, const std::string&, const std::string&>())
      .def("call", &Service::call, "flat"_a, "timeout"_a = 0.0, "into"_a.none() = nb::none())
      .def("start_async", &Service::start_async)
      .def("poll_async", &Service::poll_async, "timeout"_a = 0.0)
      .def("abort_async", &Service::abort_async)
      .def("async_notification_fd", &Service::async_notification_fd)
      .def("abort", &Service::abort)
      .def("set_handler", &Service::set_handler, "handler"_a, "request_buffer"_a.none() = nb::none())
      .def("register", &Service::register_in_group, "group_name"_a = nb::none())
      .def("get_fd", &Service::get_fd)
      .def("release", &Service::release);

  const WithClient with_client = [](nb::handle client, const std::function<void(ln_client)>& body) {
    Client& native = nb::cast<Client&>(client);
    Use use(*native.state());
    body(native.handle());
  };
  register_introspection(m, with_client);
  register_loggers(m, with_client);
  register_parameters(m, with_client);
}
