// links_and_nodes._ln: subscriptions (InPort) and the packets they lend
// (Loan); publications (OutPort) are in ports.cpp.
#pragma once

#include "client.hpp"

namespace lnpy {

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
    const int ret = without_gil([&] {
      return ln_subscribe_with_buffers(state_->handle, topic.c_str(), md_name.c_str(), &port_, rate, reliable ? 1 : 0,
                                       buffers);
    });
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

}  // namespace lnpy
