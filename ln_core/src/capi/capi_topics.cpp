// ln.h: publishing, subscribing, reading, writing and the multi-waiter.
// read/write are the hot path: a handle check and a direct call, no locks
// beyond the port's own.
#include "capi/capi_support.hpp"
#include "client/multi_waiter.hpp"
#include "client/ports.hpp"

using ln::capi::client_from;
using ln::capi::guarded;
using ln::capi::require;
using ln::clientlib::Client;
using ln::clientlib::InPort;
using ln::clientlib::MultiWaiter;
using ln::clientlib::OutPort;
using ln::clientlib::PortBase;
using ln::clientlib::PortKind;

namespace {

InPort* inport_from(void* handle) noexcept {
  PortBase* port = PortBase::from_handle(handle);
  return port != nullptr && port->kind() == PortKind::inport ? static_cast<InPort*>(port) : nullptr;
}

OutPort* outport_from(void* handle) noexcept {
  PortBase* port = PortBase::from_handle(handle);
  return port != nullptr && port->kind() == PortKind::outport ? static_cast<OutPort*>(port) : nullptr;
}

}  // namespace

extern "C" {

// ---------------------------------------------------------------- publish

int ln_publish(ln_client clnt, const char* topic_name, const char* message_definition_name, ln_outport* port) {
  return ln_publish_with_buffers(clnt, topic_name, message_definition_name, 1, port);
}

int ln_publish_with_buffers(ln_client clnt, const char* topic_name, const char* message_definition_name,
                            unsigned int buffers, ln_outport* port) {
  Client* client = client_from(clnt);
  if (client == nullptr) return -LNE_CLIENT_NOT_INITIALIZED;
  return guarded(client, [&] {
    require(topic_name != nullptr, "topic_name");
    require(message_definition_name != nullptr, "message_definition_name");
    require(port != nullptr, "port");
    *port = client->publish(topic_name, message_definition_name, buffers);
    return 0;
  });
}

int ln_unpublish(ln_outport* port) {
  if (port == nullptr) return -LNE_INVALID_PARAMETER;
  OutPort* outport = outport_from(*port);
  if (outport == nullptr) return -LNE_INVALID_PORT_OBJECT;
  Client* client = outport->owner();
  const int ret = guarded(client, [&] {
    client->unpublish(outport);
    return 0;
  });
  if (ret == 0) *port = nullptr;
  return ret;
}

int ln_has_subscriber(ln_outport port) {
  OutPort* outport = outport_from(port);
  return outport != nullptr ? outport->subscribers() : -LNE_INVALID_PORT_OBJECT;
}

int ln_write(ln_outport port, void* packet, unsigned int size, double* timestamp) {
  OutPort* outport = outport_from(port);
  return outport != nullptr ? outport->write(packet, size, timestamp) : -LNE_INVALID_PORT_OBJECT;
}

int ln_outport_get_next_buffer(ln_outport port, void** buffer, unsigned int* buffer_len) {
  OutPort* outport = outport_from(port);
  return outport != nullptr ? outport->next_buffer(buffer, buffer_len) : -LNE_INVALID_PORT_OBJECT;
}

// -------------------------------------------------------------- subscribe

int ln_subscribe(ln_client clnt, const char* topic_name, const char* message_definition_name, ln_inport* port,
                 double rate, int reliable_transport) {
  return ln_subscribe_with_buffers(clnt, topic_name, message_definition_name, port, rate, reliable_transport, 1);
}

int ln_subscribe_with_buffers(ln_client clnt, const char* topic_name, const char* message_definition_name,
                              ln_inport* port, double rate, int reliable_transport, unsigned int buffers) {
  Client* client = client_from(clnt);
  if (client == nullptr) return -LNE_CLIENT_NOT_INITIALIZED;
  return guarded(client, [&] {
    require(topic_name != nullptr, "topic_name");
    require(port != nullptr, "port");
    *port = client->subscribe(topic_name, message_definition_name != nullptr ? message_definition_name : "", rate,
                              buffers, reliable_transport != 0);
    return 0;
  });
}

int ln_unsubscribe(ln_inport* port) {
  if (port == nullptr) return -LNE_INVALID_PARAMETER;
  InPort* inport = inport_from(*port);
  if (inport == nullptr) return -LNE_INVALID_PORT_OBJECT;
  Client* client = inport->owner();
  const int ret = guarded(client, [&] {
    client->unsubscribe(inport);
    return 0;
  });
  if (ret == 0) *port = nullptr;
  return ret;
}

int ln_has_publisher(ln_inport port) {
  InPort* inport = inport_from(port);
  return inport != nullptr ? (inport->has_publisher() ? 1 : 0) : -LNE_INVALID_PORT_OBJECT;
}

int ln_read(ln_inport port, void* packet, unsigned int size, double* timestamp, int blocking) {
  InPort* inport = inport_from(port);
  if (inport == nullptr) return -LNE_INVALID_PORT_OBJECT;
  ln_sample_info info;
  const int ret = inport->read(packet, size, &info, blocking != 0 ? -1.0 : 0.0);
  if (ret == 1 && timestamp != nullptr) *timestamp = info.timestamp;
  return ret;
}

int ln_read_timeout(ln_inport port, void* packet, unsigned int packet_size, double* ts, double timeout) {
  InPort* inport = inport_from(port);
  if (inport == nullptr) return -LNE_INVALID_PORT_OBJECT;
  ln_sample_info info;
  const int ret = inport->read(packet, packet_size, &info, timeout > 0 ? timeout : 0.0);
  if (ret == 1 && ts != nullptr) *ts = info.timestamp;
  return ret;
}

int ln_read_with_info(ln_inport port, void* packet, unsigned int size, ln_sample_info* info, double timeout) {
  InPort* inport = inport_from(port);
  return inport != nullptr ? inport->read(packet, size, info, timeout) : -LNE_INVALID_PORT_OBJECT;
}

int ln_read_borrow(ln_inport port, const void** packet, unsigned int* size, ln_sample_info* info, double timeout) {
  InPort* inport = inport_from(port);
  return inport != nullptr ? inport->borrow(packet, size, info, timeout) : -LNE_INVALID_PORT_OBJECT;
}

int ln_read_release(ln_inport port) {
  InPort* inport = inport_from(port);
  return inport != nullptr ? inport->release_borrow() : -LNE_INVALID_PORT_OBJECT;
}

int ln_unblock(ln_inport port) {
  InPort* inport = inport_from(port);
  if (inport == nullptr) return -LNE_INVALID_PORT_OBJECT;
  inport->unblock();
  return 0;
}

int ln_get_message_size(void* p_) {
  PortBase* port = PortBase::from_handle(p_);
  return port != nullptr ? static_cast<int>(port->message_size()) : -LNE_INVALID_PORT_OBJECT;
}

const char* ln_get_msg_def_hash(void* p_) {
  PortBase* port = PortBase::from_handle(p_);
  return port != nullptr ? port->hash().c_str() : nullptr;
}

// ----------------------------------------------------------- multi-waiter
// An ln_multi_waiter is the MultiWaiter itself; its client owns it.

int ln_multi_waiter_init(ln_client clnt, ln_multi_waiter* waiter) {
  Client* client = client_from(clnt);
  if (client == nullptr) return -LNE_CLIENT_NOT_INITIALIZED;
  return guarded(client, [&] {
    require(waiter != nullptr, "waiter");
    *waiter = client->create_multi_waiter();
    return 0;
  });
}

int ln_multi_waiter_deinit(ln_multi_waiter* waiter) {
  if (waiter == nullptr || *waiter == nullptr) return -LNE_INVALID_PARAMETER;
  auto* multi_waiter = static_cast<MultiWaiter*>(*waiter);
  Client* client = client_from(multi_waiter->owner());
  if (client == nullptr || !client->destroy_multi_waiter(multi_waiter)) return -LNE_INVALID_PARAMETER;
  *waiter = nullptr;
  return 0;
}

int ln_multi_waiter_add_port(ln_multi_waiter waiter, ln_inport port) {
  InPort* inport = inport_from(port);
  if (waiter == nullptr) return -LNE_INVALID_PARAMETER;
  if (inport == nullptr) return -LNE_INVALID_PORT_OBJECT;
  static_cast<MultiWaiter*>(waiter)->add_port(inport);
  return 0;
}

int ln_multi_waiter_remove_port(ln_multi_waiter waiter, ln_inport port) {
  InPort* inport = inport_from(port);
  if (waiter == nullptr) return -LNE_INVALID_PARAMETER;
  if (inport == nullptr) return -LNE_INVALID_PORT_OBJECT;
  return static_cast<MultiWaiter*>(waiter)->remove_port(inport) ? 0 : -LNE_PORT_NOT_FOUND;
}

int ln_multi_waiter_wait(ln_multi_waiter waiter, double timeout) {
  if (waiter == nullptr) return -LNE_INVALID_PARAMETER;
  auto* multi_waiter = static_cast<MultiWaiter*>(waiter);
  return guarded(multi_waiter->owner(), [&] { return multi_waiter->wait(timeout); });
}

int ln_multi_waiter_can_read(ln_multi_waiter waiter, ln_inport port) {
  InPort* inport = inport_from(port);
  if (waiter == nullptr) return -LNE_INVALID_PARAMETER;
  if (inport == nullptr) return -LNE_INVALID_PORT_OBJECT;
  return static_cast<MultiWaiter*>(waiter)->can_read(inport) ? 1 : 0;
}

int ln_multi_waiter_start_pipe_notifier_thread(ln_multi_waiter waiter, ln_pipe_fd_t* fd) {
  if (waiter == nullptr) return -LNE_INVALID_PARAMETER;
  auto* multi_waiter = static_cast<MultiWaiter*>(waiter);
  return guarded(multi_waiter->owner(), [&] {
    const int notification_fd = multi_waiter->start_pipe_notifier();
    if (fd != nullptr) *fd = notification_fd;
    return 0;
  });
}

int ln_multi_waiter_ack_pipe_notification(ln_multi_waiter waiter) {
  if (waiter == nullptr) return -LNE_INVALID_PARAMETER;
  return static_cast<MultiWaiter*>(waiter)->acknowledge();
}

}  // extern "C"
