// A small program written the way LN 2.9 C++ programs are written (publisher,
// subscriber, service caller and provider), using only LN 2.9 API. It must
// compile unchanged against ln_core's headers. Compile-only: it is never
// linked or run. The message types are spelled out here as ln_generate
// would emit them, so the check needs no generator.
#include <ln/ln.h>

#include <cstdio>
#include <cstring>
#include <iostream>
#include <string>

// -- what ln_generate would produce for counter/count_message and
//    example/add_service (layout and naming as generated) --
#include "ln/packed.h"
struct LN_PACKED counter_count_message_struct {
  uint32_t count;
  double time;
};
typedef struct counter_count_message_struct counter_count_message_t;
#define COUNTER_COUNT_MESSAGE_MD_NAME "counter/count_message|0"

typedef struct LN_PACKED {
  struct LN_PACKED example_add_service_request_t {
    double a;
    double b;
  } req;
  struct LN_PACKED example_add_service_response_t {
    double sum;
    uint32_t comment_len;
    char* comment;
  } resp;
} example_add_service_t;
#include "ln/endpacked.h"
#define example_add_service_signature "double 8 1,double 8 1|double 8 1,uint32_t 4 1,char* 1 1"

namespace example {
typedef example_add_service_t add_service_t;

class add_service_base {
 public:
  virtual ~add_service_base() { unregister_add_service(); }

 private:
  static int cb(::ln::client&, ::ln::service_request& req, void* user_data) {
    add_service_base* self = (add_service_base*)user_data;
    add_service_t data;
    req.set_data(&data, example_add_service_signature);
    memset(&data.resp, 0, sizeof(data.resp));
    return self->on_add_service(req, data);
  }

 protected:
  ::ln::service* svc;
  add_service_base() : svc(NULL) {}
  void unregister_add_service() {
    if (svc) {
      svc->clnt->release_service(svc);
      svc = NULL;
    }
  }
  void register_add_service(::ln::client* clnt, const std::string service_name, const char* group_name = NULL) {
    svc = clnt->get_service_provider(service_name, "example/add_service", example_add_service_signature);
    svc->set_handler(&cb, this);
    svc->do_register(group_name);
  }
  virtual int on_add_service(::ln::service_request& req, add_service_t& data) = 0;
};
}  // namespace example

// -- the program --

class adder : public example::add_service_base {
 public:
  explicit adder(ln::client& clnt) : clnt(clnt) { register_add_service(&clnt, "example.add"); }

  int on_add_service(ln::service_request& req, example::add_service_t& svc) override {
    svc.resp.sum = svc.req.a + svc.req.b;
// LN 2.9's string_buffer takes the field's address, and fields of generated
// structs are packed: GCC warns about that with any LN headers.
#if defined(__GNUC__) && !defined(__clang__) && __GNUC__ >= 9
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Waddress-of-packed-member"
#endif
    ln::string_buffer comment(&svc.resp.comment, "computed by " + clnt.name);
#if defined(__GNUC__) && !defined(__clang__) && __GNUC__ >= 9
#pragma GCC diagnostic pop
#endif
    req.respond();
    return 0;
  }

  void run() {
    for (int i = 0; i < 10; i++) clnt.wait_and_handle_service_group_requests(NULL, 0.5);
  }

 private:
  ln::client& clnt;
};

static int publish_counter(ln::client& clnt) {
  ln::outport* port = clnt.publish("counter.topic", COUNTER_COUNT_MESSAGE_MD_NAME);
  counter_count_message_t packet;
  memset(&packet, 0, sizeof(packet));
  for (unsigned int i = 0; i < 100; i++) {
    packet.count = i;
    packet.time = ln_get_time();
    port->write(&packet, packet.time);
    ln_sleep_seconds(0.01);
  }
  if (!port->has_subscriber()) printf("nobody listened\n");
  clnt.unpublish(port);
  return 0;
}

static int subscribe_counter(ln::client& clnt) {
  ln::inport* port = clnt.subscribe("counter.topic", "counter/count_message", RATE_AS_PUBLISHED, 3);
  ln::multi_waiter* waiter = clnt.get_multi_waiter();
  waiter->add_port(port);
  counter_count_message_t packet;
  while (waiter->wait(1.0)) {
    if (!port->read(&packet, false)) continue;
    printf("count %u at %f (sent %f)\n", packet.count, packet.time, port->timestamp);
  }
  if (port->read(&packet, 0.5)) printf("late packet %u\n", packet.count);
  return 0;
}

static int call_adder(ln::client& clnt) {
  ln::service* svc = clnt.get_service("example.add", "example/add_service", example_add_service_signature);
  example::add_service_t data;
  memset(&data, 0, sizeof(data));
  data.req.a = 1.5;
  data.req.b = 2.5;
  try {
    svc->call(&data);
    std::cout << "sum " << data.resp.sum << ": " << std::string(data.resp.comment, data.resp.comment_len) << std::endl;
  } catch (const ln::exception& e) {
    std::cerr << "call failed: " << e.what() << " (" << ln_format_error(-e.error) << ")" << std::endl;
    return 1;
  }
  ln::service_request* req = svc->call_async(&data);
  while (!req->finished()) ln_sleep_seconds(0.001);
  clnt.release_service(svc);
  return 0;
}

int main(int argc, char* argv[]) {
  try {
    ln::client clnt("ln29 style program", argc, argv);
    std::vector<std::string> args = clnt.get_remaining_args();
    std::string mode = args.size() > 1 ? args[1] : "publish";
    if (mode == "publish") return publish_counter(clnt);
    if (mode == "subscribe") return subscribe_counter(clnt);
    if (mode == "call") return call_adder(clnt);
    adder provider(clnt);
    provider.run();
  } catch (std::exception& e) {
    fprintf(stderr, "error: %s\n", e.what());
    return 1;
  }
  return 0;
}
