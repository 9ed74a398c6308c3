// Name and error probe of the LN 2.9 behaviour tests, written as for LN 2.9
// (C++ API, plus ln_write from the C API for the size probes). Compiled
// unchanged against LN 2.9 and against ln_core.
//
// usage: lnbt_probe MODE CODE_NAME [MODE ARGS] [LN options]
//   client                     ln::client(CODE_NAME, argc, argv)
//   client_to ADDRESS          ln::client(CODE_NAME, ADDRESS)
//   hold SECONDS               client, then stay connected until stdin closes
//                              or SECONDS pass
//   publish TOPIC MD [SECONDS] client, publish TOPIC (definition MD), hold
//   subscribe TOPIC MD         client, subscribe TOPIC
//   write_sizes TOPIC MD       client, publish, then ln_write with
//                              message_size, message_size + 1 and
//                              message_size - 1 bytes
// Prints "name <final name>", "args <remaining args joined by '|'>", then one
// line per step ("published size N", "write +1 ERROR" ...), "ready" when
// holding; on an exception "error <LNE_NAME>" (exit status 3), details on stderr.
#include <ln/ln.h>
#include <poll.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "lnbt_errors.h"

namespace {

using lnbt::error_name;
using lnbt::report_exception;

// Holds until stdin reaches EOF (the test closes it) or `seconds` pass.
void hold(double seconds) {
  std::printf("ready\n");
  std::fflush(stdout);
  const double deadline = ln_get_monotonic_time() + seconds;
  for (;;) {
    const double left = deadline - ln_get_monotonic_time();
    if (left <= 0) return;
    pollfd in{0, POLLIN, 0};
    if (::poll(&in, 1, static_cast<int>(left * 1000) + 1) > 0) {
      char buffer[64];
      if (::read(0, buffer, sizeof buffer) <= 0) return;
    }
  }
}

std::string joined(const std::vector<std::string>& items) {
  std::string text;
  for (const std::string& item : items) text += (text.empty() ? "" : "|") + item;
  return text;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr, "usage: lnbt_probe MODE CODE_NAME [MODE ARGS] [LN options]\n");
    return 2;
  }
  const std::string mode = argv[1];
  const std::string code_name = argv[2];
  auto arg = [&](int i) -> std::string { return i < argc ? argv[i] : ""; };
  ln::client* clnt = nullptr;
  try {
    if (mode == "client_to")
      clnt = new ln::client(code_name, arg(3));
    else
      clnt = new ln::client(code_name, argc, argv);
    std::printf("name %s\n", clnt->name.c_str());
    std::printf("args %s\n", joined(clnt->get_remaining_args()).c_str());
    std::fflush(stdout);
    if (mode == "hold") {
      hold(std::strtod(arg(3).c_str(), nullptr));
    } else if (mode == "publish") {
      ln::outport* port = clnt->publish(arg(3), arg(4));
      std::printf("published size %u\n", port->message_size);
      std::fflush(stdout);
      if (!arg(5).empty() && arg(5)[0] != '-') hold(std::strtod(arg(5).c_str(), nullptr));
      clnt->unpublish(port);
    } else if (mode == "subscribe") {
      ln::inport* port = clnt->subscribe(arg(3), arg(4));
      std::printf("subscribed size %u\n", port->message_size);
      clnt->unsubscribe(port);
    } else if (mode == "write_sizes") {
      ln::outport* port = clnt->publish(arg(3), arg(4));
      const unsigned size = port->message_size;
      std::vector<char> data(size + 16, 0);
      std::printf("write =  %s\n", error_name(ln_write(port->port, data.data(), size, nullptr)).c_str());
      std::printf("write +1 %s\n", error_name(ln_write(port->port, data.data(), size + 1, nullptr)).c_str());
      std::printf("write -1 %s\n", error_name(ln_write(port->port, data.data(), size - 1, nullptr)).c_str());
      clnt->unpublish(port);
    } else if (mode != "client" && mode != "client_to") {
      std::fprintf(stderr, "lnbt_probe: unknown mode '%s'\n", mode.c_str());
      delete clnt;
      return 2;
    }
  } catch (const ln::exception& e) {
    const int status = report_exception("lnbt_probe", e);
    delete clnt;
    return status;
  }
  std::fflush(stdout);
  delete clnt;
  return 0;
}
