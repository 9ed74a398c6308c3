// Round trip of a small service call between two processes over a Unix
// socketpair: our framing + marshalling + dispatch, against a raw socket
// ping-pong and two designs we did not choose. One JSON line per result.
//
//   service_rtt_bench [--modes raw,direct,pool,timeout,hop,message,codec]
//                     [--cpus same,split] [--n 20000] [--warmup 2000] [--runs 3]
//                     [--spin-us 20] [--gap-us 0]
//
// modes:
//   raw      64-byte ping-pong with read()/write(): the kernel's floor
//   direct   ServiceCaller -> provider thread in wait_and_handle() (the design)
//   pool     the provider group handed to a one-thread pool
//   timeout  as direct, but calls with a timeout (ppoll before each read)
//   hop      our frames and marshalling, but the provider reads in an I/O
//            thread and hands requests to a handler thread (the design the
//            brief sketched: peer server + dispatch queue)
//   message  the provider serves directly, but requests and responses travel
//            as protocol::Message (wire.hpp) instead of our frames
//   codec    no I/O: encoding + decoding cost of one call, frames vs Message
// cpus: same = both processes on CPU 0, split = caller on 0, provider on 1.
// spin-us: WaitPolicy of caller and provider (direct, pool, timeout); 0 =
// sleep at once. gap-us: pause between calls (not timed), so that the
// provider's spin has run out and each request has to wake it.
#include <poll.h>
#include <sched.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <cstring>
#include <deque>
#include <functional>
#include <mutex>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "protocol/wire.hpp"
#include "services/call_state.hpp"
#include "services/dispatch.hpp"
#include "services/socket_io.hpp"
#include "services_test_messages.h"

namespace {

using namespace ln::services;
using Clock = std::chrono::steady_clock;

struct Options {
  std::vector<std::string> modes{"raw", "direct", "pool", "timeout", "hop", "message", "codec"};
  std::vector<std::string> cpus{"same", "split"};
  int n = 20000;
  int warmup = 2000;
  int runs = 3;
  unsigned spin_us = WaitPolicy{}.spin_us;
  unsigned gap_us = 0;
};

std::vector<std::string> split_list(const std::string& text) {
  std::vector<std::string> out;
  std::stringstream in(text);
  for (std::string item; std::getline(in, item, ',');)
    if (!item.empty()) out.push_back(item);
  return out;
}

void pin_to(int cpu) {
  if (cpu < 0) return;
  cpu_set_t set;
  CPU_ZERO(&set);
  CPU_SET(cpu, &set);
  sched_setaffinity(0, sizeof set, &set);
}

std::shared_ptr<const ServiceSignature> add_signature() {
  std::shared_ptr<const ServiceSignature> s;
  ServiceSignature::compile_shared(svc_test_add_signature, s);
  return s;
}

int add_handler(void*, void* request, void*) {
  auto& r = *provider_request(request);
  svc_test_add_t d;
  if (!r.set_data(&d, svc_test_add_signature).ok()) return -LNE_SVC_RECV_REQ;
  d.resp.sum = d.req.a + d.req.b;
  return r.respond().code();
}

// ------------------------------------------------------------- providers

[[noreturn]] void provide_raw(int fd) {
  char buffer[64];
  for (;;) {
    std::size_t got = 0;
    while (got < sizeof buffer) {
      const ssize_t n = ::read(fd, buffer + got, sizeof buffer - got);
      if (n <= 0) _exit(0);
      got += static_cast<std::size_t>(n);
    }
    if (::write(fd, buffer, sizeof buffer) != static_cast<ssize_t>(sizeof buffer)) _exit(0);
  }
}

[[noreturn]] void provide_dispatch(int fd, bool pool, unsigned spin_us) {
  Dispatcher dispatcher(nullptr, Limits{}, WaitPolicy{spin_us});
  dispatcher.add_provider(1, "add", add_signature(), add_handler, nullptr, pool ? "g" : nullptr);
  dispatcher.adopt_connection(fd, 1);
  if (pool) {
    dispatcher.handle_in_pool("g", "p");
    for (;;) ::pause();
  }
  for (;;) dispatcher.wait_and_handle(nullptr, -1);
}

// The alternative: an I/O thread reads, a handler thread handles.
[[noreturn]] void provide_with_hop(int fd) {
  const auto signature = add_signature();
  std::mutex mutex;
  std::condition_variable arrived;
  std::deque<frames::Payload> queue;
  std::thread handler([&] {
    frames::FrameBuffer out;
    Arena arena;
    for (;;) {
      frames::Payload payload;
      {
        std::unique_lock<std::mutex> lock(mutex);
        arrived.wait(lock, [&] { return !queue.empty(); });
        payload = std::move(queue.front());
        queue.pop_front();
      }
      frames::RequestHead head;
      frames::parse_request(payload, head);
      svc_test_add_t d;
      arena.clear();
      unflatten(signature->request(), payload.data() + frames::header_size, payload.size() - frames::header_size, &d,
                {}, arena);
      d.resp.sum = d.req.a + d.req.b;
      std::size_t body = 0;
      flat_size(signature->response(), &d.resp, {}, body);
      out.resize(frames::response_overhead({}) + body);
      frames::write_response_head(out.data(), {head.request_id, 0}, {}, body);
      write_flat(signature->response(), &d.resp, out.data() + frames::response_overhead({}));
      if (io::send_all(fd, out.data(), out.size(), io::Deadline()).outcome != io::Outcome::Done) _exit(0);
    }
  });
  frames::FrameAssembler assembler(1 << 20);
  for (;;) {
    frames::Payload payload;
    Status malformed;
    if (io::receive_frame(fd, assembler, io::Deadline(), payload, malformed).outcome != io::Outcome::Done) _exit(0);
    {
      std::lock_guard<std::mutex> lock(mutex);
      queue.push_back(std::move(payload));
    }
    arrived.notify_one();
  }
}

// Direct serving, but with protocol::Message as the framing.
[[noreturn]] void provide_with_messages(int fd) {
  const auto signature = add_signature();
  ln::protocol::FrameReader reader;
  Arena arena;
  char buffer[65536];
  for (;;) {
    const ssize_t n = ::read(fd, buffer, sizeof buffer);
    if (n <= 0) _exit(0);
    reader.append(buffer, static_cast<std::size_t>(n));
    while (auto request = reader.next()) {
      std::string flat = request->get_string("request");
      request->get_int("service_id");
      svc_test_add_t d;
      arena.clear();
      unflatten(signature->request(), flat.data(), flat.size(), &d, {}, arena);
      d.resp.sum = d.req.a + d.req.b;
      std::string response_flat;
      flatten(signature->response(), &d.resp, {}, response_flat);
      const std::string frame =
          ln::protocol::encode(ln::protocol::Message::response_to(*request).set("response", std::move(response_flat)));
      if (io::send_all(fd, frame.data(), frame.size(), io::Deadline()).outcome != io::Outcome::Done) _exit(0);
    }
  }
}

// --------------------------------------------------------------- callers

using OneCall = std::function<bool()>;

OneCall raw_caller(int fd) {
  return [fd] {
    char buffer[64] = {1};
    if (::write(fd, buffer, sizeof buffer) != static_cast<ssize_t>(sizeof buffer)) return false;
    std::size_t got = 0;
    while (got < sizeof buffer) {
      const ssize_t n = ::read(fd, buffer + got, sizeof buffer - got);
      if (n <= 0) return false;
      got += static_cast<std::size_t>(n);
    }
    return true;
  };
}

OneCall service_caller(int fd, double timeout, unsigned spin_us) {
  auto handed_out = std::make_shared<bool>(false);
  auto caller = std::make_shared<ServiceCaller>(
      add_signature(),
      [fd, handed_out](ProviderLink& link) {
        if (*handed_out) return Status::failure(LNE_NO_PROVIDER_FOUND, "connection lost");
        *handed_out = true;
        link.fd = fd;
        link.service_id = 1;
        return Status();
      },
      nullptr, Limits{}, WaitPolicy{spin_us});
  auto counter = std::make_shared<int>(0);
  return [caller, counter, timeout] {
    svc_test_add_t d{};
    d.req.a = ++*counter;
    d.req.b = 1;
    return caller->call(&d, timeout) == 0 && d.resp.sum == *counter + 1;
  };
}

OneCall message_caller(int fd) {
  struct State {
    std::shared_ptr<const ServiceSignature> signature = add_signature();
    ln::protocol::FrameReader reader;
    Arena arena;
    std::uint32_t id = 0;
    char buffer[65536];
  };
  auto state = std::make_shared<State>();
  return [fd, state] {
    svc_test_add_t d{};
    d.req.a = static_cast<int32_t>(++state->id);
    d.req.b = 1;
    std::string flat;
    flatten(state->signature->request(), &d, {}, flat);
    const std::string frame = ln::protocol::encode(
        ln::protocol::Message::request(state->id, "call").set("service_id", 1).set("request", flat));
    if (io::send_all(fd, frame.data(), frame.size(), io::Deadline()).outcome != io::Outcome::Done) return false;
    for (;;) {
      if (auto response = state->reader.next()) {
        std::string body = response->get_string("response");
        state->arena.clear();
        unflatten(state->signature->response(), body.data(), body.size(), &d.resp, {}, state->arena);
        return d.resp.sum == d.req.a + 1;
      }
      const ssize_t n = ::read(fd, state->buffer, sizeof state->buffer);
      if (n <= 0) return false;
      state->reader.append(state->buffer, static_cast<std::size_t>(n));
    }
  };
}

// ----------------------------------------------------------------- runs

struct Summary {
  double median_us = 0;
  double p99_us = 0;
  double min_us = 0;
};

Summary summarize(std::vector<double>& samples_us) {
  std::sort(samples_us.begin(), samples_us.end());
  Summary s;
  s.min_us = samples_us.front();
  s.median_us = samples_us[samples_us.size() / 2];
  s.p99_us = samples_us[std::min(samples_us.size() - 1, samples_us.size() * 99 / 100)];
  return s;
}

bool measure_process_pair(const std::string& mode, const std::string& cpus, const Options& options,
                          std::vector<Summary>& results) {
  for (int run = 0; run < options.runs; ++run) {
    int fds[2];
    if (::socketpair(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0, fds) != 0) return false;
    const pid_t child = ::fork();
    if (child < 0) return false;
    if (child == 0) {
      ::close(fds[0]);
      pin_to(cpus == "same" ? 0 : cpus == "split" ? 1 : -1);
      if (mode == "raw") provide_raw(fds[1]);
      if (mode == "hop") provide_with_hop(fds[1]);
      if (mode == "message") provide_with_messages(fds[1]);
      provide_dispatch(fds[1], mode == "pool", options.spin_us);
    }
    ::close(fds[1]);
    pin_to(cpus == "same" || cpus == "split" ? 0 : -1);
    OneCall call = mode == "raw"       ? raw_caller(fds[0])
                   : mode == "message" ? message_caller(fds[0])
                                       : service_caller(fds[0], mode == "timeout" ? 5.0 : 0.0, options.spin_us);
    bool ok = true;
    for (int i = 0; i < options.warmup && ok; ++i) ok = call();
    std::vector<double> samples;
    samples.reserve(static_cast<std::size_t>(options.n));
    for (int i = 0; i < options.n && ok; ++i) {
      if (options.gap_us > 0) std::this_thread::sleep_for(std::chrono::microseconds(options.gap_us));
      const auto start = Clock::now();
      ok = call();
      samples.push_back(std::chrono::duration<double, std::micro>(Clock::now() - start).count());
    }
    call = nullptr;  // closes our end (the caller owns it)
    ::kill(child, SIGKILL);
    ::waitpid(child, nullptr, 0);
    if (mode == "raw" || mode == "message") ::close(fds[0]);
    if (!ok) return false;
    results.push_back(summarize(samples));
  }
  pin_to(-1);
  return true;
}

// Encoding + decoding work of one call (request and response), no I/O.
void measure_codec(const Options& options) {
  const auto signature = add_signature();
  const int n = options.n * 10;
  Arena arena;
  svc_test_add_t d{};
  d.req.a = 1;
  d.req.b = 2;
  d.resp.sum = 3;

  auto time_it = [&](const char* name, const std::function<void()>& one) {
    for (int run = 0; run < options.runs; ++run) {
      const auto start = Clock::now();
      for (int i = 0; i < n; ++i) one();
      const double ns = std::chrono::duration<double, std::nano>(Clock::now() - start).count() / n;
      std::printf("{\"bench\":\"service_codec\",\"framing\":\"%s\",\"run\":%d,\"ns_per_call\":%.1f}\n", name, run, ns);
    }
  };

  frames::FrameBuffer out;
  time_it("frames", [&] {
    // Caller: request frame.
    std::size_t body = 0;
    flat_size(signature->request(), &d, {}, body);
    out.resize(frames::request_overhead + body);
    frames::write_request_head(out.data(), {1, 7}, body);
    write_flat(signature->request(), &d, out.data() + frames::request_overhead);
    // Provider: payload, header, data.
    frames::Payload request;
    request.allocate(out.size() - frames::size_prefix);
    std::memcpy(request.data(), out.data() + frames::size_prefix, request.size());
    frames::RequestHead head;
    frames::parse_request(request, head);
    svc_test_add_t p;
    arena.clear();
    unflatten(signature->request(), request.data() + frames::header_size, request.size() - frames::header_size, &p, {},
              arena);
    // Provider: response frame; caller: its data.
    flat_size(signature->response(), &d.resp, {}, body);
    out.resize(frames::response_overhead({}) + body);
    frames::write_response_head(out.data(), {head.request_id, 0}, {}, body);
    write_flat(signature->response(), &d.resp, out.data() + frames::response_overhead({}));
    frames::Payload response;
    response.allocate(out.size() - frames::size_prefix);
    std::memcpy(response.data(), out.data() + frames::size_prefix, response.size());
    frames::ResponseHead rhead;
    std::string_view text;
    std::size_t offset = 0;
    frames::parse_response(response, rhead, text, offset);
    unflatten(signature->response(), response.data() + offset, response.size() - offset, &p.resp, {}, arena);
  });

  time_it("message", [&] {
    std::string flat;
    flatten(signature->request(), &d, {}, flat);
    const std::string request_frame =
        ln::protocol::encode(ln::protocol::Message::request(7, "call").set("service_id", 1).set("request", flat));
    const ln::protocol::Message request = ln::protocol::decode_payload(std::string_view(request_frame).substr(4));
    std::string got = request.get_string("request");
    request.get_int("service_id");
    svc_test_add_t p;
    arena.clear();
    unflatten(signature->request(), got.data(), got.size(), &p, {}, arena);
    std::string response_flat;
    flatten(signature->response(), &d.resp, {}, response_flat);
    const std::string response_frame =
        ln::protocol::encode(ln::protocol::Message::response_to(request).set("response", response_flat));
    const ln::protocol::Message response = ln::protocol::decode_payload(std::string_view(response_frame).substr(4));
    std::string body = response.get_string("response");
    unflatten(signature->response(), body.data(), body.size(), &p.resp, {}, arena);
  });
}

}  // namespace

int main(int argc, char** argv) {
  Options options;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string key = argv[i];
    const std::string value = argv[i + 1];
    if (key == "--modes")
      options.modes = split_list(value);
    else if (key == "--cpus")
      options.cpus = split_list(value);
    else if (key == "--n")
      options.n = std::max(1, std::atoi(value.c_str()));
    else if (key == "--warmup")
      options.warmup = std::max(0, std::atoi(value.c_str()));
    else if (key == "--runs")
      options.runs = std::max(1, std::atoi(value.c_str()));
    else if (key == "--spin-us")
      options.spin_us = static_cast<unsigned>(std::max(0, std::atoi(value.c_str())));
    else if (key == "--gap-us")
      options.gap_us = static_cast<unsigned>(std::max(0, std::atoi(value.c_str())));
    else {
      std::fprintf(stderr, "unknown option %s\n", key.c_str());
      return 2;
    }
  }
  ::signal(SIGPIPE, SIG_IGN);
  for (const std::string& mode : options.modes) {
    if (mode == "codec") {
      measure_codec(options);
      continue;
    }
    for (const std::string& cpus : options.cpus) {
      std::vector<Summary> results;
      if (!measure_process_pair(mode, cpus, options, results)) {
        std::fprintf(stderr, "mode %s cpus %s failed\n", mode.c_str(), cpus.c_str());
        return 1;
      }
      for (std::size_t run = 0; run < results.size(); ++run)
        std::printf(
            "{\"bench\":\"service_rtt\",\"mode\":\"%s\",\"cpus\":\"%s\",\"spin_us\":%u,\"gap_us\":%u,"
            "\"run\":%zu,\"n\":%d,\"median_us\":%.2f,\"p99_us\":%.2f,\"min_us\":%.2f}\n",
            mode.c_str(), cpus.c_str(), options.spin_us, options.gap_us, run, options.n, results[run].median_us,
            results[run].p99_us, results[run].min_us);
      std::fflush(stdout);
    }
  }
  return 0;
}
