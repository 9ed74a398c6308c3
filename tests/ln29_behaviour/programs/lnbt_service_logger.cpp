// Service logger probe of the LN 2.9 behaviour tests
// (ln_register_as_service_logger, ln::client::register_as_service_logger and
// the generated ln::log_service_base), written as for LN 2.9; compiled
// unchanged against LN 2.9 and ln_core, each run against its own manager.
//
// usage: lnbt_service_logger PREFIX [LN options]
// Three clients: a logger providing PREFIX.log, a provider of PREFIX.echo,
// PREFIX.late and PREFIX.secret (excluded by the patterns), and a caller. Prints the error cases, then one
// line per logged call in call order: both log items, with what is
// deterministic (times and ids only as relations), then "items N".
// On an unexpected exception: "error <LNE_NAME>" (exit 3).
#include <ln/ln.h>

#include <algorithm>
#include <atomic>
#include <cstdio>
#include <cstring>
#include <map>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "ln_messages.h"
#include "lnbt_errors.h"

namespace {

using lnbt::error_name;

struct Item {
  std::string client, service, interface, peer, data;
  unsigned type, flags;
  double completion, transfer, request_time;
  uint32_t client_id, request_id;
  uint64_t thread_id;
};

std::mutex items_mutex;
std::vector<Item> items;

std::string str(const char* p, uint32_t n) { return p != nullptr ? std::string(p, n) : std::string(); }

struct Logger : ln::log_service_base {
  Logger(ln::client& clnt, const std::string& name) { register_log_service(&clnt, name); }
  int on_log_service(ln::service_request& req, ln::log_service_t& d) override {
    const auto& r = d.req;
    Item item{str(r.client_name, r.client_name_len),
              str(r.service_name, r.service_name_len),
              str(r.service_interface, r.service_interface_len),
              str(r.peer_address, r.peer_address_len),
              std::string(reinterpret_cast<const char*>(r.data), r.data_len),
              r.item_type,
              r.flags,
              r.completion_time,
              r.transfer_time,
              r.request_time,
              r.client_id,
              r.request_id,
              r.thread_id};
    {
      std::lock_guard<std::mutex> lock(items_mutex);
      items.push_back(item);
    }
    d.resp.error_message = const_cast<char*>("");
    d.resp.error_message_len = 0;
    req.respond();
    return 0;
  }
};

struct Echo : lnbt::echo_base {
  Echo(ln::client& clnt, const std::string& name) { register_echo(&clnt, name); }
  int on_echo(ln::service_request& req, lnbt::echo_t& d) override {
    if (d.req.fail != 0) return d.req.fail;
    d.resp.text = d.req.text;
    d.resp.text_len = d.req.text_len;
    req.respond();
    return 0;
  }
};

std::string hex(const std::string& bytes) {
  std::string out;
  char digits[3];
  for (unsigned char c : bytes) {
    std::snprintf(digits, sizeof digits, "%02x", c);
    out += digits;
  }
  return out;
}

uint32_t u32_at(const std::string& bytes, std::size_t at) {
  uint32_t v = 0;
  if (bytes.size() >= at + 4) std::memcpy(&v, bytes.data() + at, 4);
  return v;
}

// A request item's data: u32 size | u16 version | u32 client id | u32
// request id | flat request; the ids are shown as relations, not values.
std::string request_data(const Item& item) {
  const std::string& d = item.data;
  if (d.size() < 14) return "short " + hex(d);
  return "size_ok " + std::string(u32_at(d, 0) == d.size() ? "yes" : "no") + " head " + hex(d.substr(4, 2)) +
         " ids_as_fields " + (u32_at(d, 6) == item.client_id && u32_at(d, 10) == item.request_id ? "yes" : "no") +
         " flat " + hex(d.substr(14));
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: lnbt_service_logger PREFIX [LN options]\n");
    return 2;
  }
  const std::string prefix = argv[1];
  const double started = ln_get_time();
  try {
    ln::client logger_client("lnbt_logger", argc, argv);
    ln::client provider_client("lnbt_log_provider", argc, argv);
    ln::client caller_client("lnbt_log_caller", argc, argv);
    Echo foreign(provider_client, prefix + "x.foreign");  // not matched by the patterns
    Logger logger(logger_client, prefix + ".log");
    std::atomic<bool> stop{false};
    std::thread serve_logger([&] {
      while (!stop) logger_client.wait_and_handle_service_group_requests(nullptr, 0.05);
    });
    std::thread serve_provider([&] {
      while (!stop) provider_client.wait_and_handle_service_group_requests(nullptr, 0.05);
    });

    std::printf(
        "not_own_service %s\n",
        error_name(ln_register_as_service_logger(logger_client.clnt, (prefix + "x.foreign").c_str(), "*")).c_str());
    std::printf("unknown_service %s\n",
                error_name(ln_register_as_service_logger(logger_client.clnt, (prefix + ".none").c_str(), "*")).c_str());
    logger_client.register_as_service_logger(prefix + ".log", prefix + ".*,!" + prefix + ".secret");
    std::printf("registered\n");
    std::fflush(stdout);
    // LN 2.9's provider hangs when the manager tells it about a logger of a
    // service it provides already; these come after the logger.
    Echo echo(provider_client, prefix + ".echo");
    Echo secret(provider_client, prefix + ".secret");
    Echo late(provider_client, prefix + ".late");

    struct Call {
      std::string service, text;
      int fail;
    };
    const std::vector<Call> calls = {
        {".echo", "one", 0}, {".echo", "two", 7}, {".secret", "hidden", 0}, {".late", "three", 0}};
    std::map<std::string, ln::service*> handles;
    for (const Call& c : calls) {
      ln::service*& handle = handles[c.service];
      if (handle == nullptr) handle = caller_client.get_service(prefix + c.service, "lnbt/echo", lnbt_echo_signature);
      lnbt::echo_t data;
      std::memset(&data, 0, sizeof data);
      std::string text = c.text;
      data.req.text = &text[0];
      data.req.text_len = static_cast<uint32_t>(text.size());
      data.req.fail = c.fail;
      try {
        handle->call(&data);
        std::printf("call %s%s ok\n", c.service.c_str(), c.text.c_str());
      } catch (const ln::exception& e) {
        std::printf("call %s%s %s\n", c.service.c_str(), c.text.c_str(), error_name(e.error).c_str());
      }
    }
    // Two items per logged call (three calls); then a moment for any extra.
    const double deadline = ln_get_monotonic_time() + 10;
    for (;;) {
      {
        std::lock_guard<std::mutex> lock(items_mutex);
        if (items.size() >= 6 || ln_get_monotonic_time() > deadline) break;
      }
      ln_sleep_seconds(0.02);
    }
    ln_sleep_seconds(0.5);
    stop = true;
    serve_logger.join();
    serve_provider.join();
    const double ended = ln_get_time();

    std::lock_guard<std::mutex> lock(items_mutex);
    // Pair the items of each call by (client id, request id); show them in
    // call order (by the request's text).
    std::vector<std::pair<std::string, std::string>> lines;
    for (const Item& request : items) {
      if (request.type != 0) continue;
      const Item* response = nullptr;
      for (const Item& candidate : items)
        if (candidate.type == 1 && candidate.client_id == request.client_id &&
            candidate.request_id == request.request_id)
          response = &candidate;
      std::string line = "request from " + request.client + " service " + request.service + " iface " +
                         request.interface + " flags " + std::to_string(request.flags) + " in_time " +
                         (request.completion >= started && request.completion <= ended ? "yes" : "no") +
                         " transfer_ok " + (request.transfer >= 0 && request.transfer < 5 ? "yes" : "no") +
                         " request_time " + (request.request_time == 0 ? "0" : "set") + " thread " +
                         (request.thread_id != 0 ? "set" : "0") + " " + request_data(request);
      if (response == nullptr) {
        line += " | no response item";
      } else {
        line += " | response from " + response->client + " service " + response->service + " iface " +
                response->interface + " flags " + std::to_string(response->flags) + " in_time " +
                (response->completion >= started && response->completion <= ended ? "yes" : "no") + " request_time " +
                (response->request_time >= started && response->request_time <= response->completion ? "ok" : "bad") +
                " same_peer " + (response->peer == request.peer && !request.peer.empty() ? "yes" : "no") + " data " +
                hex(response->data);
      }
      lines.emplace_back(request.data.substr(std::min<std::size_t>(14, request.data.size())), line);
    }
    std::sort(lines.begin(), lines.end());
    for (const auto& entry : lines) std::printf("%s\n", entry.second.c_str());
    std::printf("items %zu\n", items.size());
  } catch (const ln::exception& e) {
    std::printf("error %s\n", error_name(e.error).c_str());
    std::fprintf(stderr, "lnbt_service_logger: %s\n", e.what());
    return 3;
  }
  return 0;
}
