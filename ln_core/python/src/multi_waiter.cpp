// links_and_nodes._ln: the multi-waiter (ln_multi_waiter_*).
#include "ports.hpp"

using namespace nb::literals;

namespace lnpy {
namespace {

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
}  // namespace

void register_multi_waiter(nb::module_& m) {
  nb::class_<MultiWaiter>(m, "MultiWaiter")
      .def(nb::init<Client&>())
      .def("add_port", &MultiWaiter::add_port)
      .def("remove_port", &MultiWaiter::remove_port)
      .def("wait", &MultiWaiter::wait, "timeout"_a = -1.0)
      .def("can_read", &MultiWaiter::can_read)
      .def("start_pipe_notifier_thread", &MultiWaiter::start_pipe_notifier_thread)
      .def("ack_pipe_notification", &MultiWaiter::ack_pipe_notification);
}

}  // namespace lnpy
