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

namespace {

struct ErrorName {
  int code;
  const char* name;
};

#define LNBT_E(x) {x, #x}
const ErrorName error_names[] = {
    LNBT_E(LNE_CHECK_ERRNO), LNBT_E(LNE_NO_MEM), LNBT_E(LNE_NO_MANAGER_ADDRESS), LNBT_E(LNE_INVALID_MANAGER_ADDRESS),
    LNBT_E(LNE_INVALID_HOSTNAME), LNBT_E(LNE_UNKNOWN_HOSTNAME), LNBT_E(LNE_HOST_WRONG_NET),
    LNBT_E(LNE_GOT_INVALID_RESPONSE), LNBT_E(LNE_REGISTER_DENIED), LNBT_E(LNE_CLIENT_NOT_INITIALIZED),
    LNBT_E(LNE_REQUEST_FAILED), LNBT_E(LNE_FIELD_NOT_IN_HEADER), LNBT_E(LNE_STRING_LENGTH_SPEC_MISSING),
    LNBT_E(LNE_PORT_NOT_FOUND), LNBT_E(LNE_INVALID_PORT_OBJECT), LNBT_E(LNE_SHM_IS_TOO_SMALL),
    LNBT_E(LNE_SHM_IS_TOO_BIG), LNBT_E(LNE_SHM_DOES_NOT_EXIT), LNBT_E(LNE_PACKET_TOO_LARGE),
    LNBT_E(LNE_SHM_READ_ERROR), LNBT_E(LNE_LOST_CONNECTION), LNBT_E(LNE_REGISTER_FAILED),
    LNBT_E(LNE_SVC_IS_PROVIDER), LNBT_E(LNE_SVC_IS_CLIENT), LNBT_E(LNE_SVC_RECV_RESP), LNBT_E(LNE_SVC_RECV_RESP_MEM),
    LNBT_E(LNE_SVC_ALREADY_REGISTERED), LNBT_E(LNE_SVC_NOT_REGISTERED), LNBT_E(LNE_SVC_RECV_REQ),
    LNBT_E(LNE_SVC_RECV_REQ_MEM), LNBT_E(LNE_SVC_REQ_SET_DATA_WRONG), LNBT_E(LNE_SVC_HANDLER_NO_RESP),
    LNBT_E(LNE_INVALID_REQ_FIELD_FORMAT), LNBT_E(LNE_USER_DEFINED_ERROR), LNBT_E(LNE_SVC_NO_HANDLER),
    LNBT_E(LNE_SVC_HANDLER_EXC), LNBT_E(LNE_SVC_REQ_RUNNING), LNBT_E(LNE_SVC_REQ_NOT_RUNNING),
    LNBT_E(LNE_SVC_REQ_ABORTED), LNBT_E(LNE_NO_PROVIDER_FOUND), LNBT_E(LNE_START_PROVIDER_FAILED),
    LNBT_E(LNE_ERROR_GETTING_SHM_FD), LNBT_E(LNE_SHM_NAME_TOO_LONG), LNBT_E(LNE_NOT_YET_IMPLEMENTED),
    LNBT_E(LNE_NO_LOGGER_TOPICS), LNBT_E(LNE_INTERNAL_ERROR), LNBT_E(LNE_TOPIC_ID_OUT_OF_RANGE),
    LNBT_E(LNE_LOG_FILE_TOO_NEW), LNBT_E(LNE_WRONG_BYTE_ORDER), LNBT_E(LNE_INVALID_SHM_MAGIC),
    LNBT_E(LNE_SHM_VERSION_TOO_NEW), LNBT_E(LNE_WRONG_SHM_SIZE), LNBT_E(LNE_INVALID_SIGNATURE),
    LNBT_E(LNE_INVALID_PARAMETER), LNBT_E(LNE_SVC_RESP_LATER), LNBT_E(LNE_SVC_GRP_UNKNOWN),
    LNBT_E(LNE_THREADP_INIT), LNBT_E(LNE_NOT_ON_THIS_OS), LNBT_E(LNE_PORT_UNBLOCKED), LNBT_E(LNE_UNKNOWN_PARAMETER),
    LNBT_E(LNE_SVC_HANDLER_MULTI_RESP), LNBT_E(LNE_MANAGER_TOO_OLD), LNBT_E(LNE_INVALID_DSA_SIGNATURE),
    LNBT_E(LNE_SVC_TIMEOUT), LNBT_E(LNE_SVC_GRP_HANDLED_IN_POOL), LNBT_E(LNE_CLNT_NAME_IN_USE),
    LNBT_E(LNE_CHECK_ERROR_CODE), LNBT_E(LNE_UNKNOWN), LNBT_E(LNE_WRONG_MD_HASH),
};
#undef LNBT_E

std::string error_name(int code) {
  if (code < 0) code = -code;
  if (code == 0) return "OK";
  for (const ErrorName& e : error_names)
    if (e.code == code) return e.name;
  return "LNE_#" + std::to_string(code);
}

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
    std::printf("error %s\n", error_name(e.error).c_str());
    std::fprintf(stderr, "lnbt_probe: %s (error %d, error_code %d)\n", e.what(), static_cast<int>(e.error),
                 e.error_code);
    std::fflush(stdout);
    delete clnt;
    return 3;
  }
  std::fflush(stdout);
  delete clnt;
  return 0;
}
