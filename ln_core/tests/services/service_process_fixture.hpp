// The fixture of the cross-process service tests: a manager in this
// process, a C client ("driver") connected to it, LN 2.9-style provider
// programs (ln_svc_provider*.c/cpp) started on demand, and calling handles
// for svc/test.
#pragma once

#include <gtest/gtest.h>
#include <ln/ln.h>

#include <cstdint>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include "client/client_test_support.hpp"
#include "ln_messages.h"
#include "svc_provider_modes.h"

namespace ln::servicetest {

using namespace ln::clienttest;

class ServiceProcessTest : public ::testing::Test {
 protected:
  void SetUp() override { ASSERT_EQ(ln_init_to_manager(&client_, "driver", manager_.address().c_str()), 0); }
  void TearDown() override {
    for (ln_service& svc : services_) ln_service_deinit(&svc);
    if (client_ != nullptr) ln_deinit(&client_);
  }
  /// Starts a provider program serving `name` once it said "ready".
  std::unique_ptr<ChildProcess> provider(const std::vector<std::string>& extra = {},
                                         const char* program = LN_SVC_PROVIDER, const char* name = "svc") {
    std::vector<std::string> args = {program, name};
    args.insert(args.end(), extra.begin(), extra.end());
    auto child = std::make_unique<ChildProcess>(args, manager_.address());
    EXPECT_NE(child->wait_for_line("ready"), "");
    return child;
  }
  /// A calling handle of the driver, released at the end of the test.
  ln_service caller(const char* name = "svc", const char* signature = svc_test_signature) {
    ln_service svc = nullptr;
    EXPECT_EQ(ln_service_init(client_, &svc, name, "svc/test", signature), 0);
    services_.push_back(svc);
    return svc;
  }
  /// One ln_service_call_with_timeout() in `mode`; last_count_ gets resp.count.
  int call(ln_service svc, int mode, unsigned delay_ms = 0, double timeout = 0, int error = 0) {
    svc_test_t data;
    std::memset(&data, 0, sizeof data);
    data.req.mode = mode;
    data.req.delay_ms = delay_ms;
    data.req.error = error;
    last_count_ = 0;
    const int ret = ln_service_call_with_timeout(svc, &data, timeout);
    last_count_ = data.resp.count;
    return ret;
  }
  std::string error_message() const { return ln_get_error_message(client_); }

  InProcessManager manager_;
  ln_client client_ = nullptr;
  std::vector<ln_service> services_;
  uint32_t last_count_ = 0;
};

}  // namespace ln::servicetest
