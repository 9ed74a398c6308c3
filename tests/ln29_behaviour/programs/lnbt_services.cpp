// Service probe of the LN 2.9 behaviour tests, written as for LN 2.9 (C++
// API, plus the C API where the C++ one hides the return code). Compiled
// unchanged against LN 2.9 and against ln_core.
//
// usage: lnbt_services MODE [MODE ARGS] [LN options]
//   provide SERVICE             provides SERVICE (lnbt/echo: answers the text
//                               reversed, or fails with `fail`); "ready", then
//                               serves until stdin closes or 30 s pass
//   call SERVICE TEXT [FAIL]    one call; "reply <text>" or
//                               "call error <LNE_NAME> code <error_code>"
//   introspect INTERFACE SERVICE...
//                               get_service_signature(INTERFACE),
//                               get_service_signature_for_service(SERVICE)
//                               for each, find_services_with_interface(INTERFACE)
//   sched                       ln_thread_pool_setschedparam() on a pool that
//                               serves a group, with RLIMIT_RTPRIO 0: one line
//                               per case, "<case> <LNE_NAME or OK>"
// On an unexpected exception: "error <LNE_NAME>" (exit status 3).
#include <ln/ln.h>
#include <poll.h>
#include <sched.h>
#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "ln_messages.h"
#include "lnbt_errors.h"

namespace {

// The program's arguments, for a second client in sched mode.
struct {
  int argc = 0;
  char** argv = nullptr;
} clnt_manager_args;

using lnbt::error_name;
using lnbt::report_exception;

struct Provider : lnbt::echo_base {
  Provider(ln::client& clnt, const std::string& name) { register_echo(&clnt, name); }
  int on_echo(ln::service_request& req, lnbt::echo_t& data) override {
    if (data.req.fail > 0) return data.req.fail;
    reply.assign(data.req.text, data.req.text_len);
    std::reverse(reply.begin(), reply.end());
    data.resp.text = &reply[0];
    data.resp.text_len = static_cast<uint32_t>(reply.size());
    req.respond();
    return 0;
  }
  std::string reply;
};

// Serves the default group until stdin reaches EOF or `seconds` pass.
void serve(ln::client& clnt, double seconds) {
  std::printf("ready\n");
  std::fflush(stdout);
  const double deadline = ln_get_monotonic_time() + seconds;
  while (ln_get_monotonic_time() < deadline) {
    clnt.wait_and_handle_service_group_requests(nullptr, 0.05);
    pollfd in{0, POLLIN, 0};
    if (::poll(&in, 1, 0) > 0) {
      char buffer[64];
      if (::read(0, buffer, sizeof buffer) <= 0) return;
    }
  }
}

void introspect(ln::client& clnt, const std::string& interface, const std::vector<std::string>& services) {
  char* definition = nullptr;
  char* signature = nullptr;
  int ret = ln_get_service_signature(clnt.clnt, interface.c_str(), &definition, &signature);
  std::printf("signature %s %s\n", interface.c_str(),
              ret != 0
                  ? error_name(ret).c_str()
                  : (std::strcmp(signature, lnbt_echo_signature) == 0 && definition[0] != '\0' ? "ok" : "differs"));
  if (ret == 0) {
    std::free(definition);
    std::free(signature);
  }
  for (const std::string& service : services) {
    char* found_interface = nullptr;
    ret = ln_get_service_signature_for_service(clnt.clnt, service.c_str(), &found_interface, &definition, &signature);
    if (ret != 0) {
      std::printf("for_service %s %s\n", service.c_str(), error_name(ret).c_str());
      continue;
    }
    std::printf("for_service %s interface %s signature %s\n", service.c_str(), found_interface,
                std::strcmp(signature, lnbt_echo_signature) == 0 ? "ok" : "differs");
    std::free(found_interface);
    std::free(definition);
    std::free(signature);
  }
  char* found = nullptr;
  ret = ln_client_find_services_with_interface(clnt.clnt, interface.c_str(), &found);
  if (ret != 0) {
    std::printf("find %s %s\n", interface.c_str(), error_name(ret).c_str());
    return;
  }
  // The order follows the manager's bookkeeping; the separator is the fact.
  std::vector<std::string> names;
  std::string text = found;
  std::free(found);
  for (std::size_t start = 0; !text.empty();) {
    const std::size_t end = text.find('\n', start);
    names.push_back(text.substr(start, end == std::string::npos ? std::string::npos : end - start));
    if (end == std::string::npos) break;
    start = end + 1;
  }
  std::sort(names.begin(), names.end());
  std::string joined;
  for (const std::string& name : names) joined += (joined.empty() ? "" : "|") + name;
  std::printf("find %s %zu [%s]\n", interface.c_str(), names.size(), joined.c_str());
}

// Handler: answers with the CPUs its thread may run on, as a hex mask.
int report_cpus(ln::client&, ln::service_request& req, void*) {
  lnbt::echo_t data;
  req.set_data(&data, lnbt_echo_signature);
  cpu_set_t cpus;
  CPU_ZERO(&cpus);
  unsigned mask = 0;
  if (::sched_getaffinity(0, sizeof cpus, &cpus) == 0)
    for (unsigned cpu = 0; cpu < 32; ++cpu)
      if (CPU_ISSET(cpu, &cpus)) mask |= 1u << cpu;
  char text[16];
  std::snprintf(text, sizeof text, "%x", mask);
  data.resp.text = text;
  data.resp.text_len = static_cast<uint32_t>(std::strlen(text));
  req.respond();
  return 0;
}

// The CPU masks the pool's handlers report over four calls, e.g. "1" or "1,3".
std::string pool_cpus(ln::service* caller) {
  std::vector<std::string> masks;
  for (int i = 0; i < 4; ++i) {
    lnbt::echo_t data;
    std::memset(&data, 0, sizeof data);
    caller->call(&data, 5);
    const std::string mask(data.resp.text, data.resp.text_len);
    if (std::find(masks.begin(), masks.end(), mask) == masks.end()) masks.push_back(mask);
  }
  std::sort(masks.begin(), masks.end());
  std::string joined;
  for (const std::string& mask : masks) joined += (joined.empty() ? "" : ",") + mask;
  return joined;
}

void sched_cases(ln::client& clnt) {
  // An unprivileged program: no real-time priorities (the test also runs
  // this without CAP_SYS_NICE).
  rlimit none{0, 0};
  ::setrlimit(RLIMIT_RTPRIO, &none);
  ln::service* svc = clnt.get_service_provider("lnbt.sched", "lnbt/echo", lnbt_echo_signature);
  svc->set_handler(report_cpus);
  svc->do_register("g");
  clnt.set_max_threads("p", 2);
  clnt.handle_service_group_in_thread_pool("g", "p");
  ln::client calling("lnbt_sched_caller", clnt_manager_args.argc, clnt_manager_args.argv);
  ln::service* caller = calling.get_service("lnbt.sched", "lnbt/echo", lnbt_echo_signature);
  const struct {
    const char* name;
    const char* pool;
    int policy, priority;
    unsigned mask;
  } cases[] = {
      {"other_prio0_cpu0", "p", SCHED_OTHER, 0, 1},
      {"keep_all", "p", -1, -1, 0},
      {"mask_only", "p", -1, -1, 1},
      {"other_prio5", "p", SCHED_OTHER, 5, 0},
      {"unknown_policy", "p", 12345, 0, 0},
      {"fifo_unprivileged", "p", SCHED_FIFO, 10, 0},
      {"mask_no_such_cpu", "p", -1, -1, 0x80000000u},
  };
  for (const auto& c : cases) {
    std::printf("%s %s\n", c.name,
                error_name(ln_thread_pool_setschedparam(clnt.clnt, c.pool, c.policy, c.priority, c.mask)).c_str());
    if (std::strcmp(c.name, "other_prio0_cpu0") == 0) std::printf("pool cpus %s\n", pool_cpus(caller).c_str());
  }
  std::printf("pool cpus at the end %s\n", pool_cpus(caller).c_str());
  calling.release_service(caller);
  clnt.remove_service_group_from_thread_pool("g");
  clnt.release_service(svc);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: lnbt_services MODE [MODE ARGS] [LN options]\n");
    return 2;
  }
  const std::string mode = argv[1];
  // Mode arguments end where the LN options start.
  std::vector<std::string> mode_args;
  for (int i = 2; i < argc && std::strncmp(argv[i], "-ln", 3) != 0 && std::strncmp(argv[i], "--ln", 4) != 0; ++i)
    mode_args.push_back(argv[i]);
  clnt_manager_args.argc = argc;
  clnt_manager_args.argv = argv;
  ln::client* clnt = nullptr;
  try {
    clnt = new ln::client("lnbt_services", argc, argv);
    if (mode == "provide") {
      Provider provider(*clnt, mode_args.at(0));
      serve(*clnt, 30);
    } else if (mode == "call") {
      ln::service* svc = clnt->get_service(mode_args.at(0), "lnbt/echo", lnbt_echo_signature);
      lnbt::echo_t data;
      std::memset(&data, 0, sizeof data);
      std::string text = mode_args.size() > 1 ? mode_args[1] : "";
      data.req.text = &text[0];
      data.req.text_len = static_cast<uint32_t>(text.size());
      data.req.fail = mode_args.size() > 2 ? std::atoi(mode_args[2].c_str()) : 0;
      try {
        svc->call(&data, 5);
        std::printf("reply %s\n", std::string(data.resp.text, data.resp.text_len).c_str());
      } catch (const ln::exception& e) {
        std::printf("call error %s code %d\n", error_name(e.error).c_str(), e.error_code);
        std::fprintf(stderr, "lnbt_services: %s\n", e.what());
      }
      clnt->release_service(svc);
    } else if (mode == "introspect") {
      introspect(*clnt, mode_args.at(0), std::vector<std::string>(mode_args.begin() + 1, mode_args.end()));
    } else if (mode == "sched") {
      sched_cases(*clnt);
    } else {
      std::fprintf(stderr, "lnbt_services: unknown mode '%s'\n", mode.c_str());
      delete clnt;
      return 2;
    }
  } catch (const ln::exception& e) {
    const int status = report_exception("lnbt_services", e);
    delete clnt;
    return status;
  }
  std::fflush(stdout);
  delete clnt;
  return 0;
}
