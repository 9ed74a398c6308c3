// links_and_nodes._ln: event connections (ln_event_connect_flat).
#include "client.hpp"

using namespace nb::literals;

namespace lnpy {
namespace {

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
    const int ret = without_gil([&] {
      return ln_event_connect_flat(state_->handle, &connection_, name.c_str(), connect_signature.c_str(),
                                   const_cast<char*>(connect_flat.c_str()), static_cast<uint32_t>(connect_flat.size()),
                                   &EventConnection::deliver, this);
    });
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

void register_events(nb::module_& m) {
  nb::class_<EventConnection>(m, "EventConnection")
      .def(nb::init<Client&, const std::string&, const std::string&, nb::bytes, nb::object>(), "client"_a, "name"_a,
           "connect_signature"_a, "connect_flat"_a, "callback"_a)
      .def("disconnect", &EventConnection::disconnect)
      .def_prop_ro("id", &EventConnection::id);
}

}  // namespace lnpy
