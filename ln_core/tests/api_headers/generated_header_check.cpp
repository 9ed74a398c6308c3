// Compiles a header written by ln_generate (from md/api_check) against
// <ln/ln.h>: generated provider and event base classes must find exactly the
// wrapper shapes they call. Compile-only.
#include "api_check_messages.h"

namespace {

class adder : public api_check::add_service_base {
 public:
  explicit adder(ln::client& clnt) { register_add_service(&clnt, "api_check.add", "workers"); }

  int on_add_service(ln::service_request& req, api_check::add_service_t& data) override {
    data.resp.sum = data.req.a + data.req.b;
    return req.respond();
  }
};

class notice_listener : public api_check::notice_base {
 public:
  explicit notice_listener(ln::client& clnt) {
    api_check::notice_connect_t filter{};
    connect_to_notice(&clnt, "api_check.notice", &filter);
  }
  void on_notice(api_check::notice_call_t& notice) override { (void)notice.text_len; }
};

}  // namespace

void use_generated_header(ln::client& clnt);
void use_generated_header(ln::client& clnt) {
  adder provider(clnt);
  notice_listener listener(clnt);
  api_check_sample_t sample{};
  sample.position.x = 1;
  clnt.publish("api_check.sample", API_CHECK_SAMPLE_MD_NAME)->write(&sample);
  api_check::add_service_t call{};
  clnt.get_service("api_check.add", "api_check/add_service", api_check_add_service_signature)->call(&call);
}
