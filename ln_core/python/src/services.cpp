// links_and_nodes._ln: services: calls (Service.call, with Ctrl-C aborting a
// blocking call of the main thread), providers and their requests.
#include <fcntl.h>
#include <signal.h>
#include <sys/uio.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <mutex>
#include <thread>

#include "client.hpp"

using namespace nb::literals;

namespace lnpy {
namespace {

unsigned long main_thread_ident = 0;  // only the main thread runs signal handlers

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
    const int ret = without_gil(
        [&] { return ln_service_init(state_->handle, &svc_, name.c_str(), interface.c_str(), signature.c_str()); });
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
}  // namespace

void register_services(nb::module_& m) {
  main_thread_ident = nb::cast<unsigned long>(nb::module_::import_("threading").attr("main_thread")().attr("ident"));
  m.def("set_interruptible_calls", &Service::set_interruptible,
        "Whether Ctrl-C (SIGINT) aborts blocking service calls of the main thread (default True: SIGINT is "
        "chained to abort the call, then Python's handler runs).");
  m.def("interruptible_calls", &Service::interruptible);
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
}

}  // namespace lnpy
