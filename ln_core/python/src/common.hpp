// links_and_nodes._ln: what the files of the native module share: LN errors
// (Failure, raised as LNError), the sliced waits, Python buffers and the
// state a client shares with its handles. Each file registers its part of
// the module with a register_*() function declared here; module.cpp calls
// them.
#pragma once

#include <nanobind/nanobind.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <string>

#include "ln/ln.h"

namespace nb = nanobind;

namespace lnpy {

constexpr double kSlice = 0.05;

// ----------------------------------------------------------------- errors

struct Failure {
  int code;  // LNE_* (positive)
  std::string message;
  int user_code = 0;  // with LNE_USER_DEFINED_ERROR: the provider's own error code
};

[[noreturn]] void fail(int ret, const std::string& what, ln_client clnt = nullptr);

// Names and texts go to the C API as C strings, where a NUL byte would cut
// them: "a.b\0x" would silently publish "a.b".
void require_no_nul(const std::string& value, const char* what);
void require_no_nul(const std::optional<std::string>& value, const char* what);

[[noreturn]] void throw_closed();

/// Runs a blocking libln call with the GIL released, so that other Python threads run meanwhile.
template <class Call>
auto without_gil(Call&& call) {
  nb::gil_scoped_release release;
  return call();
}

inline double now() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

// Runs step(slice_timeout) until it returns non-zero or `timeout` passed
// (timeout < 0: no limit; 0: one poll with the GIL held). Between slices
// pending signals run their Python handlers; an exception they raise
// propagates (after `on_interrupt`).
struct ClientState;
inline bool is_closed(const ClientState* state);

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
    const int ret = without_gil([&] { return step(slice); });
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
inline double timeout_argument(nb::handle value) {
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

inline bool is_closed(const ClientState* state) { return state->handle.load() == nullptr; }

// ---------------------------------------------------------- registration

/// LNError and the translation of Failure and ln::md::Error into it (common.cpp).
void register_errors(nb::module_& m);
/// Constants and module-level functions (functions.cpp).
void register_functions(nb::module_& m);
/// Client (client.cpp).
void register_client(nb::module_& m);
/// EventConnection (events.cpp).
void register_events(nb::module_& m);
/// OutPort, InPort and Loan (ports.cpp).
void register_ports(nb::module_& m);
/// MultiWaiter (multi_waiter.cpp).
void register_multi_waiter(nb::module_& m);
/// Request, Service and the interruptible-calls switch (services.cpp).
void register_services(nb::module_& m);

}  // namespace lnpy
