// A provider written as for LN 2.9 in C++: derives from the generated
// test_base. Usage: ln_svc_provider_cpp SERVICE. Echoes, or throws /
// fails with req.error when it is set.
#include <cstdio>

#include "ln_messages.h"

class provider : public svc::test_base {
 public:
  explicit provider(ln::client* clnt, const char* name) { register_test(clnt, name); }

  int on_test(ln::service_request& req, svc::test_t& data) override {
    if (data.req.error > 0) return data.req.error;
    data.resp.text_len = data.req.text_len;
    data.resp.text = data.req.text;
    data.resp.count = 2 * data.req.items_len;
    req.respond();
    return 0;
  }
};

int main(int argc, char** argv) {
  if (argc < 2) return 2;
  try {
    ln::client clnt("svc_provider_cpp", argc, argv);
    provider p(&clnt, argv[1]);
    std::printf("ready\n");
    std::fflush(stdout);
    for (;;) clnt.wait_and_handle_service_group_requests(nullptr, 1.0);
  } catch (const ln::exception& e) {
    std::printf("error %s\n", e.what());
    return 1;
  }
}
