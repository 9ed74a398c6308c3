#include "client/client.hpp"

#include <algorithm>
#include <chrono>
#include <cstring>
#include <tuple>

#include <unistd.h>

#include <cstdarg>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <thread>

#include "client/c_api.hpp"
#include "client/failure.hpp"
#include "protocol/methods.hpp"
#include "transport/shm_layout.hpp"

namespace ln::clientlib {

namespace method = protocol::method;
using protocol::Message;
using std::chrono::milliseconds;

namespace {

constexpr milliseconds kConnectTimeout{5000};
constexpr milliseconds kGoodbyeTimeout{1000};
constexpr milliseconds kPeerTimeout{2000};
// How long a publisher holds a subscriber's open_segment for the manager's
// subscribers_changed that names it; well below kPeerTimeout.
constexpr milliseconds kListingWait{500};
constexpr milliseconds kFirstBackoff{50};

std::string without_hash(const std::string& md_name) { return md_name.substr(0, md_name.find('|')); }

// The name a client gets when the code gives none: the program's.
std::string program_name(const std::vector<std::string>& remaining_args) {
  std::string name;
  if (!remaining_args.empty()) name = remaining_args.front();
  if (name.empty()) std::getline(std::ifstream("/proc/self/comm"), name);
  if (const auto slash = name.rfind('/'); slash != std::string::npos) name.erase(0, slash + 1);
  return name.empty() ? std::string("ln_client") : name;
}

int debug_level_from_environment() {
  const char* value = std::getenv("LN_DEBUG");
  if (value == nullptr || value[0] == '\0') return 0;
  char* end = nullptr;
  const long level = std::strtol(value, &end, 10);
  return end != value ? static_cast<int>(level) : 1;  // a non-number still asks for debugging
}

// LN_MANAGER_CONNECT_TIMEOUT: how many seconds a new client waits for a
// manager that does not listen yet (0, the default: fail at once, as LN 2.9).
double connect_timeout_from_environment() {
  const char* value = std::getenv("LN_MANAGER_CONNECT_TIMEOUT");
  if (value == nullptr || value[0] == '\0') return 0;
  char* end = nullptr;
  const double seconds = std::strtod(value, &end);
  if (end == value || *end != '\0' || !(seconds >= 0) || seconds > 1e6)
    throw Failure(LNE_INVALID_PARAMETER,
                  "LN_MANAGER_CONNECT_TIMEOUT='" + std::string(value) + "' is not a number of seconds (0 to 1000000)");
  return seconds;
}

// Connects, and while the manager refuses (not listening yet) tries again
// until `wait_seconds` passed, the last time at the deadline.
UniqueFd connect_waiting(const sockaddr_in& address, double wait_seconds) {
  using clock = std::chrono::steady_clock;
  const auto deadline =
      clock::now() + std::chrono::duration_cast<clock::duration>(std::chrono::duration<double>(wait_seconds));
  auto pause = milliseconds(10);
  for (;;) {
    const auto left = std::chrono::duration_cast<milliseconds>(deadline - clock::now());
    try {
      return connect_tcp(address,
                         wait_seconds > 0 ? std::clamp(left, milliseconds(1), kConnectTimeout) : kConnectTimeout);
    } catch (const Failure& failure) {
      if (wait_seconds <= 0) throw;
      if (clock::now() >= deadline) {
        char waited[32];
        std::snprintf(waited, sizeof waited, "%g", wait_seconds);
        throw Failure(failure.code(),
                      std::string(failure.what()) + " (tried for " + waited + " s, LN_MANAGER_CONNECT_TIMEOUT)");
      }
    }
    // the manager is not there yet: nothing to wait on but time
    std::this_thread::sleep_for(std::min<clock::duration>(pause, deadline - clock::now()));
    pause = std::min(pause * 2, milliseconds(200));
  }
}

std::uint64_t next_port_serial() {
  static std::atomic<std::uint64_t> counter{0};
  return ++counter;
}

std::uint32_t next_peer_request_id() {
  static std::atomic<std::uint32_t> counter{0};
  return ++counter;
}

}  // namespace

// ------------------------------------------------------------------ creation

std::unique_ptr<Client> Client::create(const char* client_name, int argc, const char* const* argv) {
  const bool exact_name = client_name != nullptr && std::strncmp(client_name, "exact:", 6) == 0;
  CommandLine command_line = parse_command_line(argc, argv, exact_name);
  const std::optional<std::string> address = command_line.manager_address;
  return connect(client_name, std::move(command_line), address);
}

std::unique_ptr<Client> Client::create_to_manager(const char* client_name, const char* manager_address) {
  CommandLine no_arguments;  // no argv: no remaining arguments either
  std::optional<std::string> address;
  if (manager_address != nullptr) address = manager_address;
  return connect(client_name, std::move(no_arguments), address);
}

std::unique_ptr<Client> Client::connect(const char* client_name, CommandLine command_line,
                                        const std::optional<std::string>& explicit_address) {
  const auto address = choose_manager_address(explicit_address, std::getenv("LN_MANAGER"));
  if (!address) throw Failure(LNE_NO_MANAGER_ADDRESS, "no manager address given");
  Settings settings;
  settings.address = parse_manager_address(*address);
  settings.resolved = resolve_ipv4(settings.address);
  const RequestedName requested = choose_client_name(client_name, std::getenv("LN_PROGRAM_NAME"),
                                                     command_line.program_name, program_name(command_line.remaining));
  settings.requested_name = requested.name;
  settings.exact = requested.exact;
  UniqueFd socket = connect_waiting(settings.resolved, connect_timeout_from_environment());
  std::unique_ptr<Client> client(new Client(std::move(settings), std::move(command_line)));
  client->start(std::move(socket));
  return client;
}

Client::Client(Settings settings, CommandLine command_line)
    : settings_(std::move(settings)),
      host_id_(std::getenv("LN_CORE_HOST_ID") != nullptr && std::getenv("LN_CORE_HOST_ID")[0] != '\0'
                   ? std::string(std::getenv("LN_CORE_HOST_ID"))
                   : host_identity()),
      remaining_args_(std::move(command_line.remaining)),
      debug_level_(debug_level_from_environment()),
      link_(
          loop_, [this](const Message& message) { on_notification(message); },
          [this](const std::string& reason) { on_disconnect(reason); }),
      peer_server_(loop_) {
  // The command line's mappings first, then the environment's, each
  // refining the result of the ones before (as LN 2.9 does).
  topic_mapping_.add_all(command_line.topic_mappings);
  topic_mapping_.add_from_environment(std::getenv("LN_MAP_TOPICS"));
  service_mapping_.add_all(command_line.service_mappings);
  service_mapping_.add_from_environment(std::getenv("LN_MAP_SERVICES"));
  for (const std::string& arg : remaining_args_) remaining_args_block_.append(arg).push_back('\0');
  set_name(settings_.requested_name);
  peer_server_.add_method(std::string(method::open_segment),
                          [this](PeerRequest& request) { serve_open_segment(request); });
  peer_server_.start(new_peer_socket_name());
}

void Client::start(UniqueFd connected_socket) {
  link_.attach(std::move(connected_socket), settings_.address.text());
  listen_for_remote_peers();
  loop_.run_after(PacketCountReports::kPeriod, [this] { report_packet_counts(); });
  loop_.start("ln:io");
  register_with_manager();
}

void Client::listen_for_remote_peers() {
  try {
    peer_server_.listen_tcp(link_.local_ip());
  } catch (const Failure& failure) {
    // Same-host peers still work over the Unix socket; remote callers cannot reach us.
    debug("no TCP peer server: %s", failure.what());
  }
}

Message Client::hello_request(bool after_restart) {
  if (after_restart) listen_for_remote_peers();  // loop thread; the local IP may have changed
  Message hello = link_.new_request(method::hello);
  hello.set("program_name", settings_.requested_name)
      .set("exact", settings_.exact)
      .set("pid", static_cast<std::int64_t>(::getpid()))
      .set("host_name", host_name())
      .set("host_id", host_id_)
      .set("uid", static_cast<std::int64_t>(::getuid()))
      .set("library_version", LN_LIBRARY_VERSION)
      .set("peer_socket", peer_server_.socket_name())
      .set("peer_address", peer_server_.tcp_address());
  if (after_restart) hello.set("previous_name", std::string(name()));
  return hello;
}

void Client::adopt_hello_response(const Message& response) {
  set_name(response.get_string("client_name"));
  client_id_.store(response.get_int("client_id"));
  if (std::string(name()).find("dbg") != std::string::npos && debug_level_.load() == 0) debug_level_.store(1);
}

void Client::register_with_manager() {
  try {
    const Message answer = link_.call(hello_request(false), kRequestTimeout);
    adopt_hello_response(answer);
  } catch (const protocol::ProtocolError& error) {
    throw Failure(LNE_GOT_INVALID_RESPONSE, std::string("registering with the ln_manager: ") + error.what());
  } catch (const Failure& failure) {
    if (failure.code() == LNE_CLNT_NAME_IN_USE || failure.code() == LNE_REQUEST_FAILED ||
        failure.code() == LNE_REGISTER_DENIED)
      throw;
    throw Failure(failure.code(), std::string("registering with the ln_manager: ") + failure.what());
  }
  registered_.store(true);
  debug("registered as '%s' (client id %lld) with the ln_manager at %s", name(), static_cast<long long>(client_id()),
        settings_.address.text().c_str());
}

void Client::set_name(const std::string& name) {
  std::lock_guard<std::mutex> lock(name_mutex_);
  const std::size_t n = std::min(name.size(), sizeof(name_) - 1);
  std::memcpy(name_, name.data(), n);
  name_[n] = '\0';
}

Client::~Client() {
  if (registered_.load()) {
    try {
      link_.call(link_.new_request(method::goodbye), kGoodbyeTimeout);
    } catch (...) {
      // The manager releases everything of ours when the connection closes anyway.
    }
  }
  registered_.store(false);
  loop_.stop();
  peer_server_.stop();
  link_.detach("the client was closed");
  connecting_.reset();
  std::shared_ptr<void> services;
  std::map<std::string, std::shared_ptr<void>> parts;
  {
    std::lock_guard<std::mutex> lock(services_mutex_);
    services.swap(services_);
    parts.swap(parts_);
  }
  parts.clear();     // first: event delivery calls services
  services.reset();  // stops its threads; handlers may still use the client
  std::lock_guard<std::mutex> lock(registry_mutex_);
  waiters_.clear();   // before the ports they look at
  outports_.clear();  // closes the segments: local subscribers see the publisher leave at once
  receiver_.reset();  // before the ports it hands rings to
  inports_.clear();
}

void Client::require_registered() const {
  if (registered_.load()) return;
  throw Failure(LNE_LOST_CONNECTION, "no connection to the ln_manager at " + settings_.address.text() +
                                         " (it was lost; reconnecting in the background, set-up calls fail "
                                         "until the manager is back)");
}

Message Client::request(Message message, milliseconds timeout, std::function<void(const Message&)> in_loop) {
  require_registered();
  return link_.call(std::move(message), timeout, std::move(in_loop));
}

double Client::ping(double timeout) {
  if (timeout == 0) {
    require_registered();
    return 0;
  }
  const auto limit = timeout < 0 || timeout > 86400.0 ? milliseconds(86400'000)
                                                      : milliseconds(static_cast<long long>(timeout * 1000.0 + 0.5));
  const auto start = std::chrono::steady_clock::now();
  request(link_.new_request(method::ping), std::max(limit, milliseconds(1)));
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

// -------------------------------------------------------------------- debug

void Client::debug(const char* format, ...) const {
  if (!debugging()) return;
  va_list args;
  va_start(args, format);
  vdebug(format, args);
  va_end(args);
}

void Client::vdebug(const char* format, va_list args) const {
  if (!debugging()) return;
  char text[2048];
  std::vsnprintf(text, sizeof text, format, args);
  timespec now{};
  ::clock_gettime(CLOCK_REALTIME, &now);
  std::string client_name;
  {
    std::lock_guard<std::mutex> lock(name_mutex_);
    client_name = name_;
  }
  // LN_DEBUG output is documented library behaviour: the one place that prints.
  std::fprintf(stderr, "ln_debug %lld.%06ld %s: %s\n", static_cast<long long>(now.tv_sec), now.tv_nsec / 1000,
               client_name.c_str(), text);
}

// ------------------------------------------------------------ extension points

void Client::add_notification_handler(std::string method_name, NotificationHandler handler) {
  auto add = [this, method_name = std::move(method_name), handler = std::move(handler)]() mutable {
    notification_handlers_[method_name].push_back(std::move(handler));
  };
  if (loop_.in_loop_thread())
    add();
  else
    loop_.post(std::move(add));
}

void Client::add_reconnect_handler(std::function<void()> handler) {
  auto add = [this, handler = std::move(handler)]() mutable { reconnect_handlers_.push_back(std::move(handler)); };
  if (loop_.in_loop_thread())
    add();
  else
    loop_.post(std::move(add));
}

std::shared_ptr<void> Client::part_state(const std::string& part, const std::function<std::shared_ptr<void>()>& make) {
  std::lock_guard<std::mutex> lock(services_mutex_);
  std::shared_ptr<void>& state = parts_[part];
  if (!state) state = make();
  return state;
}

std::shared_ptr<void> Client::services_state(const std::function<std::shared_ptr<void>()>& make) {
  std::lock_guard<std::mutex> lock(services_mutex_);
  if (!services_) services_ = make();
  return services_;
}

// ------------------------------------------------------------------ topics

bool Client::owns(const PortBase* port) const {
  std::lock_guard<std::mutex> lock(registry_mutex_);
  return registrations_.count(port) != 0;
}

OutPort* Client::find_outport_locked(std::int64_t topic_id, const std::string& topic) const {
  if (auto it = outports_by_topic_id_.find(topic_id); it != outports_by_topic_id_.end()) {
    if (topic.empty() || it->second->topic() == topic) return it->second;
  }
  if (topic.empty()) return nullptr;
  for (const auto& port : outports_)
    if (port->topic() == topic) return port.get();
  return nullptr;
}

InPort* Client::find_inport_locked(std::int64_t subscription_id) const {
  auto it = inports_by_subscription_.find(subscription_id);
  return it == inports_by_subscription_.end() ? nullptr : it->second;
}

OutPort* Client::publish(const std::string& topic_name, const std::string& md_name, unsigned buffers) {
  require_registered();
  if (md_name.empty())
    throw Failure(LNE_INVALID_PARAMETER, "publishing '" + topic_name + "' needs a message definition name");
  if (buffers < 1)
    throw Failure(LNE_INVALID_PARAMETER, "publishing '" + topic_name + "': buffers must be at least 1, not 0");
  const std::string topic = topic_mapping_.apply(topic_name);
  auto owned = std::make_unique<OutPort>(errors_, topic, without_hash(md_name), buffers);
  OutPort* port = owned.get();
  port->owner_ = this;
  {
    std::lock_guard<std::mutex> lock(registry_mutex_);
    Registration& registration = registrations_[port];
    registration.in_flight = true;
    registration.md_requested = md_name;
    registration.serial = next_port_serial();
  }
  auto forget = [&] {
    std::lock_guard<std::mutex> lock(registry_mutex_);
    for (auto it = outports_by_topic_id_.begin(); it != outports_by_topic_id_.end();)
      it = it->second == port ? outports_by_topic_id_.erase(it) : std::next(it);
    registrations_.erase(port);
  };

  std::int64_t topic_id = -1;
  std::uint32_t message_size = 0;
  std::string hash;
  try {
    Message publish = link_.new_request(method::publish);
    publish.set("topic", topic).set("message_definition", md_name).set("buffers", buffers);
    request(std::move(publish), kRequestTimeout, [&](const Message& answer) {
      topic_id = answer.get_int("topic_id");
      message_size = static_cast<std::uint32_t>(answer.get_int("message_size", 0, transport::layout::kMaxMessageSize));
      hash = answer.get_string("hash");
      port->set_segment_limit(
          static_cast<std::uint64_t>(std::max<std::int64_t>(answer.get_int_or("segment_limit", 0), 0)));
      port->want_history(static_cast<std::uint32_t>(answer.get_int_or("subscriber_buffers", 1)));
      std::lock_guard<std::mutex> lock(registry_mutex_);
      Registration& registration = registrations_.at(port);
      registration.manager_id = registration.topic_id = topic_id;
      registration.session = link_.session();
      registration.in_flight = false;
      registration.packet_reports.restart(0, PacketCountReports::Clock::now());
      outports_by_topic_id_[topic_id] = port;
    });
    port->set_recovery_handler([this, port] { loop_.post([this, port] { send_publisher_ready(port, true); }); });
    port->create_segment(message_size, hash, std::max(buffers, port->wanted_history()));
    port->ensure_history(port->wanted_history());  // a subscriber may have asked for more meanwhile
  } catch (...) {
    forget();
    if (topic_id >= 0) {
      Message unpublish = link_.new_request(method::unpublish);
      unpublish.set("topic_id", topic_id);
      link_.send_request(std::move(unpublish), [](Reply&) {});
    }
    throw;
  }

  bool registered_now;
  {
    std::lock_guard<std::mutex> lock(registry_mutex_);
    const Registration& registration = registrations_.at(port);
    registered_now = registration.manager_id >= 0 && registration.session == link_.session();
    outports_.push_back(std::move(owned));
  }
  if (!registered_now) {
    // The manager restarted during set-up, before the reconnect logic could see this port.
    loop_.post([this, port] { republish(port); });
    return port;
  }
  Message ready = link_.new_request(method::publisher_ready);
  // Nothing is written yet: the program gets the port when this returns.
  ready.set("topic_id", topic_id).set("segment_generation", port->generation()).set("packets", 0);
  try {
    link_.call(std::move(ready), kRequestTimeout);
  } catch (const Failure& failure) {
    // Losing the manager now is fine: re-registration announces the segment.
    if (failure.code() != LNE_LOST_CONNECTION) {
      unpublish(port);
      throw;
    }
  }
  debug("publishing '%s' (%s, %u bytes, %u buffers)", topic.c_str(), md_name.c_str(), message_size, buffers);
  return port;
}

template <typename Port>
std::pair<std::unique_ptr<Port>, std::int64_t> Client::forget_port(std::vector<std::unique_ptr<Port>>& ports,
                                                                   std::map<std::int64_t, Port*>& by_id, Port* port,
                                                                   const char* kind) {
  const auto found = std::find_if(ports.begin(), ports.end(), [&](const auto& p) { return p.get() == port; });
  if (found == ports.end()) throw Failure(LNE_INVALID_PORT_OBJECT, std::string("not an ") + kind + " of this client");
  std::unique_ptr<Port> owned = std::move(*found);
  ports.erase(found);
  const Registration& registration = registrations_.at(port);
  const std::int64_t manager_id = registration.session == link_.session() ? registration.manager_id : -1;
  for (auto it = by_id.begin(); it != by_id.end();) it = it->second == port ? by_id.erase(it) : std::next(it);
  registrations_.erase(port);
  return {std::move(owned), manager_id};
}

void Client::unpublish(OutPort* port) {
  std::unique_ptr<OutPort> owned;
  std::int64_t topic_id = -1;
  {
    std::lock_guard<std::mutex> lock(registry_mutex_);
    std::tie(owned, topic_id) = forget_port(outports_, outports_by_topic_id_, port, "output port");
  }
  owned.reset();  // closes the segment first: local subscribers notice at once
  if (topic_id >= 0 && registered_.load()) {
    // No need to wait: the manager handles this client's requests in order.
    Message unpublish = link_.new_request(method::unpublish);
    unpublish.set("topic_id", topic_id);
    link_.send_request(std::move(unpublish), [](Reply&) {});
  }
}

InPort* Client::subscribe(const std::string& topic_name, const std::string& md_name, double rate, unsigned buffers,
                          bool reliable) {
  require_registered();
  // LN 2.9 reserves "the next packet on request" but serves it exactly as
  // the last one: a non-blocking read fetches the newest packet.
  if (rate == RATE_ON_REQUEST_NEXT) rate = RATE_ON_REQUEST_LAST;
  if (std::isnan(rate) || (rate < 0 && rate != RATE_AS_PUBLISHED && rate != RATE_ON_REQUEST_LAST))
    throw Failure(LNE_INVALID_PARAMETER, "invalid subscription rate " + std::to_string(rate));
  if (buffers < 1)
    throw Failure(LNE_INVALID_PARAMETER, "subscribing to '" + topic_name + "': buffers must be at least 1, not 0");
  const std::string topic = topic_mapping_.apply(topic_name);
  auto owned = std::make_unique<InPort>(errors_, topic, without_hash(md_name), rate, buffers, reliable);
  InPort* port = owned.get();
  port->owner_ = this;
  std::uint64_t serial;
  std::string receive_address;
  {
    std::lock_guard<std::mutex> lock(registry_mutex_);
    if (!receiver_) {
      try {
        receiver_ = std::make_unique<RemoteReceiver>(link_.local_ip());
      } catch (const Failure& failure) {
        debug("no receiver for topic data from other hosts: %s", failure.what());
      }
    }
    if (receiver_) receive_address = receiver_->address();
    Registration& registration = registrations_[port];
    registration.in_flight = true;
    registration.md_requested = md_name;
    serial = registration.serial = next_port_serial();
  }
  try {
    Message subscribe = link_.new_request(method::subscribe);
    subscribe.set("topic", topic)
        .set("message_definition", md_name)
        .set("buffers", buffers)
        .set("rate", rate)
        .set("reliable", reliable)
        .set("receive_address", receive_address);
    request(std::move(subscribe), kRequestTimeout, [&](const Message& answer) {
      port->message_size_ =
          static_cast<std::uint32_t>(answer.get_int("message_size", 0, transport::layout::kMaxMessageSize));
      port->hash_ = answer.get_string("hash");
      port->md_name_ = without_hash(answer.get_string_or("message_definition", port->md_name_));
      if (handle_subscribe_answer(port, answer)) open_publisher_segment(port, serial, answer);
    });
  } catch (...) {
    std::lock_guard<std::mutex> lock(registry_mutex_);
    for (auto it = inports_by_subscription_.begin(); it != inports_by_subscription_.end();)
      it = it->second == port ? inports_by_subscription_.erase(it) : std::next(it);
    registrations_.erase(port);
    if (receiver_) receiver_->close_inbox(port);
    throw;
  }
  bool registered_now;
  {
    std::lock_guard<std::mutex> lock(registry_mutex_);
    const Registration& registration = registrations_.at(port);
    registered_now = registration.manager_id >= 0 && registration.session == link_.session();
    inports_.push_back(std::move(owned));
  }
  if (!registered_now) loop_.post([this, port] { resubscribe(port); });
  debug("subscribed to '%s' (%s, rate %g, %u buffers)", topic.c_str(), md_name.c_str(), rate, buffers);
  return port;
}

void Client::unsubscribe(InPort* port) {
  std::unique_ptr<InPort> owned;
  std::int64_t subscription_id = -1;
  {
    std::lock_guard<std::mutex> lock(registry_mutex_);
    std::tie(owned, subscription_id) = forget_port(inports_, inports_by_subscription_, port, "input port");
    for (const auto& waiter : waiters_) waiter->remove_port(port);
    if (receiver_) receiver_->close_inbox(port);
  }
  owned.reset();
  if (subscription_id >= 0 && registered_.load()) {
    Message unsubscribe = link_.new_request(method::unsubscribe);
    unsubscribe.set("subscription_id", subscription_id);
    link_.send_request(std::move(unsubscribe), [](Reply&) {});
  }
}

MultiWaiter* Client::create_multi_waiter() {
  auto waiter = std::make_unique<MultiWaiter>(this);
  std::lock_guard<std::mutex> lock(registry_mutex_);
  waiters_.push_back(std::move(waiter));
  return waiters_.back().get();
}

bool Client::destroy_multi_waiter(MultiWaiter* waiter) {
  std::unique_ptr<MultiWaiter> owned;
  {
    std::lock_guard<std::mutex> lock(registry_mutex_);
    auto it = std::find_if(waiters_.begin(), waiters_.end(), [&](const auto& w) { return w.get() == waiter; });
    if (it == waiters_.end()) return false;
    owned = std::move(*it);
    waiters_.erase(it);
  }
  return true;  // destroyed outside the lock: it may wait for its notifier thread
}

// Registry lock NOT held. Returns true if the answer names a publisher whose
// segment should be opened.
bool Client::handle_subscribe_answer(InPort* port, const Message& answer) {
  const std::int64_t subscription_id = answer.get_int("subscription_id");
  const std::int64_t topic_id = answer.get_int("topic_id");
  std::lock_guard<std::mutex> lock(registry_mutex_);
  auto it = registrations_.find(port);
  if (it == registrations_.end()) return false;
  Registration& registration = it->second;
  registration.manager_id = subscription_id;
  registration.topic_id = topic_id;
  registration.session = link_.session();
  registration.in_flight = false;
  inports_by_subscription_[subscription_id] = port;
  if (!answer.has("peer_socket")) return false;
  port->set_has_publisher(true);
  return true;
}

// ------------------------------------------------------------ I/O thread

void Client::on_notification(const Message& message) {
  const std::string name = message.method();
  try {
    if (name == method::publisher_available) {
      InPort* port;
      std::uint64_t serial;
      {
        std::lock_guard<std::mutex> lock(registry_mutex_);
        port = find_inport_locked(message.get_int("subscription_id"));
        if (port == nullptr) return;
        port->set_has_publisher(true);
        serial = registrations_.at(port).serial;
      }
      open_publisher_segment(port, serial, message);
    } else if (name == method::publisher_gone) {
      std::lock_guard<std::mutex> lock(registry_mutex_);
      InPort* port = find_inport_locked(message.get_int("subscription_id"));
      if (port == nullptr) return;
      port->set_has_publisher(false);
      port->forget_pending_segment();
    } else if (name == method::subscribers_changed) {
      bool grew = false;
      OutPort* port;
      {
        std::lock_guard<std::mutex> lock(registry_mutex_);
        port = find_outport_locked(message.get_int("topic_id"), std::string());
        if (port == nullptr) return;
        grew = update_subscribers_locked(port, message);
      }
      if (grew) send_publisher_ready(port);
      serve_listed_opens();
    }
  } catch (const std::exception& error) {
    debug("ignoring notification '%s': %s", name.c_str(), error.what());
  }
  if (auto handlers = notification_handlers_.find(name); handlers != notification_handlers_.end()) {
    for (auto& handler : handlers->second) handler(message);
  }
}

bool Client::update_subscribers_locked(OutPort* port, const Message& message) {
  // Grown first: what the program writes once it sees the new count has to
  // land in the segment the new subscribers are handed.
  port->want_history(static_cast<std::uint32_t>(message.get_int_or("subscriber_buffers", 1)));
  bool grew = false;
  try {
    grew = port->ensure_history(port->wanted_history());
  } catch (const Failure& failure) {
    // The subscribers still count; they read with the buffers there are.
    debug("topic '%s': %s", port->topic().c_str(), failure.what());
  }

  std::map<std::int64_t, std::uint64_t>& joined = registrations_.at(port).joined_after;
  std::map<std::int64_t, std::uint64_t> listed;
  std::optional<std::uint64_t> newest;
  auto count = [&](std::int64_t id) {
    if (auto known = joined.find(id); known != joined.end()) return listed.emplace(id, known->second).first->second;
    if (!newest) newest = port->newest_sequence();
    return listed.emplace(id, *newest).first->second;
  };
  if (message.has("local")) {
    for (const std::string& entry : message.get_list("local")) {
      char* end = nullptr;
      const long long id = std::strtoll(entry.c_str(), &end, 10);
      if (end == entry.c_str() || *end != '\0') continue;
      count(id);
    }
  }
  std::vector<RemoteTarget> targets;
  if (message.has("remote")) {
    for (const std::string& entry : message.get_list("remote")) {
      RemoteTarget target;
      if (!RemoteTarget::parse(entry, target)) continue;
      target.joined_after = count(target.subscription_id);
      targets.push_back(target);
    }
  }
  joined.swap(listed);  // subscriptions no longer listed are forgotten
  port->set_subscribers(static_cast<int>(message.get_int("subscribers")));
  port->set_remote_targets(targets);
  return grew;
}

void Client::open_publisher_segment(InPort* port, std::uint64_t serial, const Message& publisher) {
  if (publisher.get_string_or("host_id", "") != host_id_) {
    std::lock_guard<std::mutex> lock(registry_mutex_);
    auto it = registrations_.find(port);
    if (it == registrations_.end() || it->second.serial != serial) return;
    attach_remote_inbox_locked(port, it->second.manager_id, serial);
    return;
  }
  const std::string socket = publisher.get_string("peer_socket");
  std::int64_t subscription_id;
  std::int64_t topic_id;
  {
    std::lock_guard<std::mutex> lock(registry_mutex_);
    auto it = registrations_.find(port);
    if (it == registrations_.end() || it->second.serial != serial) return;
    if (port->knows_segment({socket, publisher.get_int_or("segment_generation", 0)})) return;
    subscription_id = it->second.manager_id;
    topic_id = it->second.topic_id;
  }
  Message open = Message::request(next_peer_request_id(), method::open_segment);
  open.set("topic_id", topic_id)
      .set("subscription_id", subscription_id)
      .set("topic", port->topic())
      .set("buffers", port->buffers());
  call_peer(loop_, socket, std::move(open), kPeerTimeout, [this, port, serial, socket](Reply& reply, UniqueFd fd) {
    std::lock_guard<std::mutex> lock(registry_mutex_);
    auto it = registrations_.find(port);
    if (it == registrations_.end() || it->second.serial != serial) return;  // unsubscribed meanwhile
    if (reply.error != 0 || !fd.valid()) {
      debug("topic '%s': could not open the publisher's segment: %s", port->topic().c_str(),
            reply.error != 0 ? reply.error_text.c_str() : "no descriptor received");
      return;
    }
    const SegmentIdentity identity{socket, reply.message.get_int_or("segment_generation", 0)};
    if (port->knows_segment(identity)) return;
    std::optional<std::uint64_t> written_before;
    if (const std::int64_t last = reply.message.get_int_or("last_sequence", -1); last >= 0)
      written_before = static_cast<std::uint64_t>(last);
    port->offer_segment(std::move(fd), identity, static_cast<std::uint32_t>(reply.message.get_int_or("slots", 1)),
                        written_before);
  });
}

void Client::attach_remote_inbox_locked(InPort* port, std::int64_t subscription_id, std::uint64_t serial) {
  if (!receiver_) {
    debug("topic '%s': the publisher is on another host and this client cannot receive remote data",
          port->topic().c_str());
    return;
  }
  // One inbox per subscription, whoever publishes remotely. The receiver
  // creates a ring in it for each publisher stream when its data arrives
  // and hands it to the port; each has an identity of its own, so that the
  // port switches to the new one at once.
  RemoteReceiver::InboxHandlers handlers;
  const std::string inbox = "inbox:" + receiver_->address() + "/" + std::to_string(serial) + "#";
  handlers.adopt = [port, inbox](UniqueFd ring, std::int64_t generation, std::uint64_t written_before) {
    port->offer_segment(std::move(ring), SegmentIdentity{inbox + std::to_string(generation), generation},
                        port->buffers(), written_before);
  };
  handlers.fail = [port](int code, const std::string& text) { port->fail_stream(code, text); };
  receiver_->open_inbox(port, port->message_size(), port->buffers(), std::move(handlers));
  receiver_->route(port, subscription_id);
}

void Client::serve_listed_opens() {
  std::vector<PeerRequest> listed;
  {
    std::lock_guard<std::mutex> lock(registry_mutex_);
    for (auto it = held_opens_.begin(); it != held_opens_.end();) {
      const OutPort* port = find_outport_locked(it->request.message.get_int_or("topic_id", -1),
                                                it->request.message.get_string_or("topic", ""));
      const bool counted = port == nullptr || registrations_.at(port).joined_after.count(
                                                  it->request.message.get_int_or("subscription_id", -1)) != 0;
      if (!counted) {
        ++it;
        continue;
      }
      loop_.cancel(it->timer);
      listed.push_back(std::move(it->request));
      it = held_opens_.erase(it);
    }
  }
  for (PeerRequest& request : listed) serve_open_segment(request, false);
}

void Client::serve_open_segment(PeerRequest& request, bool may_wait) {
  if (request.connection->over_tcp())
    return request.fail(LNE_REQUEST_FAILED, "shared-memory segments cannot be handed over TCP (peer on another host)");
  if (!request.connection->local_user_allowed())
    return request.fail(LNE_REQUEST_FAILED,
                        "shared-memory segments are only handed to processes of the same user "
                        "(or of users LN_PEER_ALLOW_UIDS lists)");
  const std::int64_t topic_id = request.message.get_int_or("topic_id", -1);
  const std::int64_t subscription_id = request.message.get_int_or("subscription_id", -1);
  const std::string topic = request.message.get_string_or("topic", "");
  const std::int64_t buffers = request.message.get_int_or("buffers", 1);
  OutPort::SegmentOffer offer;
  std::optional<std::uint64_t> joined_after;
  std::uint32_t message_size = 0;
  OutPort* grown = nullptr;
  {
    std::lock_guard<std::mutex> lock(registry_mutex_);
    OutPort* port = find_outport_locked(topic_id, topic);
    if (port == nullptr) return request.fail(LNE_PORT_NOT_FOUND, "this client does not publish topic '" + topic + "'");
    const Registration& registration = registrations_.at(port);
    if (may_wait && subscription_id >= 0 && registration.manager_id >= 0 && registration.session == link_.session() &&
        registration.joined_after.count(subscription_id) == 0) {
      // The manager answered the subscriber before telling us: wait for its
      // subscribers_changed, so that the subscriber gets no packet before
      // has_subscriber() counts it and every one after. A subscriber it
      // never names (an id of a manager that is gone) is answered later.
      const std::uint64_t serial = ++last_held_open_;
      const EventLoop::TimerId timer = loop_.run_after(kListingWait, [this, serial] {
        auto it = std::find_if(held_opens_.begin(), held_opens_.end(),
                               [serial](const HeldOpen& held) { return held.serial == serial; });
        if (it == held_opens_.end()) return;
        PeerRequest late = std::move(it->request);
        held_opens_.erase(it);
        serve_open_segment(late, false);
      });
      held_opens_.push_back({serial, timer, request});
      return;
    }
    // A subscriber that wants more buffers than the segment has: grow it now
    // (before the manager's subscribers_changed, which may come later), so
    // that this subscriber never reads with fewer buffers than it asked for.
    if (buffers > 1 && buffers <= transport::layout::kMaxHistory) {
      port->want_history(static_cast<std::uint32_t>(buffers));
      if (port->ensure_history(port->wanted_history())) grown = port;
    }
    offer = port->offer_segment();
    message_size = port->message_size();
    // Not listed (held for too long, or no manager): the program cannot
    // have seen this subscriber counted, so the newest packet is the right
    // starting point.
    const auto& joined = registration.joined_after;
    if (auto it = joined.find(subscription_id); it != joined.end()) joined_after = it->second;
  }
  if (grown != nullptr) send_publisher_ready(grown);
  if (!offer.fd.valid())
    return request.fail(LNE_ERROR_GETTING_SHM_FD, "the segment of topic '" + topic + "' is not ready");
  std::uint64_t last_sequence = offer.last_sequence;
  // Packets from before a segment switch are not in this one: a reader
  // must not wait for them.
  if (joined_after) last_sequence = std::max(*joined_after, offer.first_sequence - 1);
  Message answer = Message::response_to(request.message);
  answer.set("message_size", message_size)
      .set("slots", offer.slots)
      .set("segment_generation", offer.generation)
      .set("last_sequence", static_cast<std::int64_t>(last_sequence));
  request.connection->send(answer, offer.fd.get());
}

void Client::send_publisher_ready(OutPort* port, bool recovered) {
  std::int64_t topic_id;
  std::uint64_t packets;
  {
    std::lock_guard<std::mutex> lock(registry_mutex_);
    auto it = registrations_.find(port);
    if (it == registrations_.end() || it->second.manager_id < 0 || it->second.session != link_.session()) return;
    topic_id = it->second.manager_id;
    // Until publish() lists the port, the program cannot have written, and
    // publish() may still be setting up the segment.
    const bool listed =
        std::any_of(outports_.begin(), outports_.end(), [port](const auto& owned) { return owned.get() == port; });
    packets = listed ? port->packets_written() : 0;
    it->second.packet_reports.restart(packets, PacketCountReports::Clock::now());
  }
  Message ready = link_.new_request(method::publisher_ready);
  ready.set("topic_id", topic_id)
      .set("segment_generation", port->generation())
      .set("packets", static_cast<std::int64_t>(packets));
  if (recovered) {
    ready.set("recovered", static_cast<std::int64_t>(port->segment_recoveries()));
    debug("topic '%s': re-created the shared-memory segment, which was corrupted (%llu times so far)",
          port->topic().c_str(), static_cast<unsigned long long>(port->segment_recoveries()));
  }
  const std::string topic = port->topic();
  link_.send_request(std::move(ready), [this, topic](Reply& reply) {
    if (reply.error != 0) debug("announcing the segment of '%s' failed: %s", topic.c_str(), reply.error_text.c_str());
  });
}

void Client::report_packet_counts() {
  loop_.run_after(PacketCountReports::kPeriod, [this] { report_packet_counts(); });
  if (!registered_.load()) return;
  std::vector<Message> reports;
  {
    std::lock_guard<std::mutex> lock(registry_mutex_);
    const std::uint64_t session = link_.session();
    const auto now = PacketCountReports::Clock::now();
    for (const auto& port : outports_) {
      // A segment written over by a subscriber is replaced (and announced
      // through the recovery handler).
      port->check_segment();
      Registration& registration = registrations_.at(port.get());
      if (registration.manager_id < 0 || registration.session != session) continue;
      const std::uint64_t packets = port->packets_written();
      if (!registration.packet_reports.due(packets, now)) continue;
      Message report = Message::notification(method::topic_stats);
      report.set("topic_id", registration.manager_id).set("packets", static_cast<std::int64_t>(packets));
      reports.push_back(std::move(report));
    }
  }
  for (const Message& report : reports) link_.send_notification(report);
}

void Client::on_disconnect(const std::string& reason) {
  registered_.store(false);
  debug("lost the ln_manager (%s); reconnecting", reason.c_str());
  {
    std::lock_guard<std::mutex> lock(registry_mutex_);
    for (auto& [port, registration] : registrations_) {
      registration.manager_id = -1;
      registration.topic_id = -1;
      registration.in_flight = false;
      registration.joined_after.clear();  // the next manager hands out its own ids
    }
    outports_by_topic_id_.clear();
    inports_by_subscription_.clear();
  }
  backoff_ = kFirstBackoff;
  schedule_reconnect();
}

void Client::schedule_reconnect() {
  const milliseconds longest{longest_backoff_ms_.load()};
  loop_.run_after(std::min(backoff_, longest), [this] { try_reconnect(); });
  backoff_ = std::min(backoff_ * 2, longest);
}

void Client::try_reconnect() {
  if (link_.connected()) return;
  try {
    connecting_ = start_tcp_connect(settings_.resolved);
  } catch (const Failure&) {
    schedule_reconnect();
    return;
  }
  const int fd = connecting_.get();
  // A host that does not answer at all: give up this attempt after a while.
  const EventLoop::TimerId give_up = loop_.run_after(kConnectTimeout, [this, fd] {
    if (connecting_.get() != fd) return;
    loop_.unwatch(fd);
    connecting_.reset();
    schedule_reconnect();
  });
  loop_.watch(fd, POLLOUT, [this, fd, give_up](short) {
    loop_.unwatch(fd);
    loop_.cancel(give_up);
    if (connecting_.get() != fd) return;
    if (finish_connect(fd) != 0) {
      connecting_.reset();
      schedule_reconnect();
      return;
    }
    link_.attach(std::move(connecting_), settings_.address.text());
    const std::uint64_t session = link_.session();
    link_.send_request(hello_request(true), [this, session](Reply& reply) {
      if (reply.error == LNE_LOST_CONNECTION) return;  // on_disconnect schedules the next attempt
      if (reply.error != 0 || link_.session() != session) {
        debug("registering again with the ln_manager failed: %s", reply.error_text.c_str());
        link_.detach("registration refused: " + reply.error_text);
        schedule_reconnect();
        return;
      }
      try {
        adopt_hello_response(reply.message);
      } catch (const std::exception& error) {
        link_.detach(std::string("invalid registration answer: ") + error.what());
        schedule_reconnect();
        return;
      }
      registered_.store(true);
      backoff_ = kFirstBackoff;
      debug("registered again as '%s' with the ln_manager at %s", name(), settings_.address.text().c_str());
      on_reconnected();
    });
  });
}

void Client::on_reconnected() {
  std::vector<OutPort*> outports;
  std::vector<InPort*> inports;
  {
    std::lock_guard<std::mutex> lock(registry_mutex_);
    for (const auto& port : outports_) outports.push_back(port.get());
    for (const auto& port : inports_) inports.push_back(port.get());
  }
  for (OutPort* port : outports) republish(port);
  for (InPort* port : inports) resubscribe(port);
  for (auto& handler : reconnect_handlers_) handler();
}

std::optional<Client::ClaimedRegistration> Client::claim_registration(const PortBase* port) {
  std::lock_guard<std::mutex> lock(registry_mutex_);
  auto it = registrations_.find(port);
  if (it == registrations_.end()) return std::nullopt;
  Registration& registration = it->second;
  if (registration.in_flight || (registration.manager_id >= 0 && registration.session == link_.session()))
    return std::nullopt;
  registration.in_flight = true;
  return ClaimedRegistration{registration.serial, registration.md_requested};
}

void Client::republish(OutPort* port) {
  const std::optional<ClaimedRegistration> claimed = claim_registration(port);
  if (!claimed) return;
  const std::uint64_t serial = claimed->serial;
  const std::string& md_name = claimed->md_name;
  Message publish = link_.new_request(method::publish);
  publish.set("topic", port->topic()).set("message_definition", md_name).set("buffers", port->buffers());
  link_.send_request(std::move(publish), [this, port, serial](Reply& reply) {
    bool grew = false;
    {
      std::lock_guard<std::mutex> lock(registry_mutex_);
      auto it = registrations_.find(port);
      if (it == registrations_.end() || it->second.serial != serial) {
        // Unpublished meanwhile: the manager must not keep the topic for us.
        if (reply.error == 0) {
          Message unpublish = link_.new_request(method::unpublish);
          unpublish.set("topic_id", reply.message.get_int_or("topic_id", -1));
          link_.send_request(std::move(unpublish), [](Reply&) {});
        }
        return;
      }
      Registration& registration = it->second;
      registration.in_flight = false;
      if (reply.error != 0) {
        debug("publishing '%s' again failed: %s", port->topic().c_str(), reply.error_text.c_str());
        errors_.set("publishing '" + port->topic() + "' again after a manager restart failed: " + reply.error_text);
        return;
      }
      try {
        const std::int64_t topic_id = reply.message.get_int("topic_id");
        registration.manager_id = registration.topic_id = topic_id;
        registration.session = link_.session();
        outports_by_topic_id_[topic_id] = port;
        port->set_subscribers(0);  // the manager announces the subscribers as they come back
        port->want_history(static_cast<std::uint32_t>(reply.message.get_int_or("subscriber_buffers", 1)));
        grew = port->ensure_history(port->wanted_history());
      } catch (const std::exception& error) {
        debug("publishing '%s' again: %s", port->topic().c_str(), error.what());
      }
    }
    (void)grew;  // either way the (possibly new) segment is announced now
    send_publisher_ready(port);
  });
}

void Client::resubscribe(InPort* port) {
  const std::optional<ClaimedRegistration> claimed = claim_registration(port);
  if (!claimed) return;
  const std::uint64_t serial = claimed->serial;
  const std::string& md_name = claimed->md_name;
  Message subscribe = link_.new_request(method::subscribe);
  subscribe.set("topic", port->topic())
      .set("message_definition", md_name)
      .set("buffers", port->buffers())
      .set("rate", port->rate())
      .set("reliable", port->reliable())
      .set("receive_address", receiver_ ? receiver_->address() : std::string());
  link_.send_request(std::move(subscribe), [this, port, serial](Reply& reply) {
    {
      std::lock_guard<std::mutex> lock(registry_mutex_);
      auto it = registrations_.find(port);
      if (it == registrations_.end() || it->second.serial != serial) {
        // Unsubscribed meanwhile: the manager must not keep the subscription.
        if (reply.error == 0) {
          Message unsubscribe = link_.new_request(method::unsubscribe);
          unsubscribe.set("subscription_id", reply.message.get_int_or("subscription_id", -1));
          link_.send_request(std::move(unsubscribe), [](Reply&) {});
        }
        return;
      }
      it->second.in_flight = false;
      if (reply.error != 0) {
        debug("subscribing to '%s' again failed: %s", port->topic().c_str(), reply.error_text.c_str());
        errors_.set("subscribing to '" + port->topic() + "' again after a manager restart failed: " + reply.error_text);
        return;
      }
    }
    try {
      if (handle_subscribe_answer(port, reply.message)) open_publisher_segment(port, serial, reply.message);
    } catch (const std::exception& error) {
      debug("subscribing to '%s' again: %s", port->topic().c_str(), error.what());
    }
  });
}

}  // namespace ln::clientlib
