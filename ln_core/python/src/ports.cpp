// links_and_nodes._ln: topics (see ports.hpp).
#include "ports.hpp"

#include <nanobind/stl/optional.h>

using namespace nb::literals;

namespace lnpy {
namespace {

// ------------------------------------------------------------------ topics

class OutPort {
 public:
  OutPort(Client& client, const std::string& topic, const std::string& md_name, unsigned int buffers)
      : state_(client.state()) {
    require_no_nul(topic, "the topic name");
    require_no_nul(md_name, "the message definition name");
    Use use(*state_);
    const int ret = without_gil(
        [&] { return ln_publish_with_buffers(state_->handle, topic.c_str(), md_name.c_str(), buffers, &port_); });
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

}  // namespace

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

namespace {

PyType_Slot loan_slots[] = {{Py_bf_getbuffer, reinterpret_cast<void*>(Loan::getbuffer)},
                            {Py_bf_releasebuffer, reinterpret_cast<void*>(Loan::releasebuffer)},
                            {0, nullptr}};

}  // namespace

void register_ports(nb::module_& m) {
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
}

}  // namespace lnpy
