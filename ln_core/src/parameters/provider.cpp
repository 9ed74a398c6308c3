#include "parameters/provider.hpp"

#include <chrono>
#include <condition_variable>
#include <cstdlib>
#include <cstring>
#include <map>
#include <mutex>
#include <optional>
#include <vector>

#include "client/failure.hpp"
#include "ln_parameter_messages.h"
#include "parameters/diagnostics.hpp"
#include "parameters/pattern.hpp"
#include "parameters/remote.hpp"
#include "parameters/topic_layout.hpp"
#include "parameters/values.hpp"

namespace ln::paramcore {

using clientlib::Failure;

namespace {

constexpr const char* kGroup = "parameter_services";
constexpr const char* kPool = "parameter_service_pool";
constexpr unsigned kPoolThreads = 4;
// How long an override with wait_step waits for the block's next update.
constexpr std::chrono::seconds kWaitStepTimeout{10};
// How long a block publishes its topic after a request_parameter_topic
// (then only while it has subscribers), as LN 2.9.
constexpr std::chrono::seconds kTopicRequestLifetime{10};

std::string no_step_error(const std::string& block_name) {
  return "no update() of parameter block '" + block_name + "' within " + std::to_string(kWaitStepTimeout.count()) +
         " s; the override takes effect at its next update()";
}

bool environment_flag(const char* name) {
  const char* value = std::getenv(name);
  return value != nullptr && value[0] != '\0' && std::strcmp(value, "0") != 0;
}

}  // namespace

struct SignalState {
  std::string full_name;
  std::string description;
  ElementType type = ElementType::Double;
  Shape shape;
  bool row_major = true;
  void* input = nullptr;
  void* output = nullptr;
  ln_parameter_check before_update = nullptr;
  ln_parameter_applied after_update = nullptr;
  void* user_data = nullptr;

  std::vector<std::uint8_t> input_value;     // row-major
  std::vector<std::uint8_t> output_value;    // row-major: the value in effect
  std::vector<std::uint8_t> override_value;  // row-major
  bool override_enabled = false;
  bool apply_pending = false;  // after_update not called yet for the override

  std::size_t bytes() const { return shape.elements() * element_size(type); }
  /// `row` (row-major) in the program's layout.
  std::vector<std::uint8_t> program_layout(const std::vector<std::uint8_t>& row) const {
    std::vector<std::uint8_t> out(row.size());
    from_row_major(row.data(), out.data(), type, shape, row_major);
    return out;
  }
};

struct BlockTopic {
  std::string name;
  std::string message_definition;
  ln_outport port = nullptr;
  std::vector<std::size_t> order;  // signals in packet order
  std::vector<std::uint8_t> packet;
  std::chrono::steady_clock::time_point requested_until{};
};

struct BlockState {
  std::string name;
  std::vector<SignalState> signals;
  bool registered = false;
  bool closed = false;
  bool always_publish = false;
  std::string topic_name;             // "" = "<client name>.<block name>"
  std::unique_ptr<BlockTopic> topic;  // once published
  // Updates started (inputs read, overrides applied) and completed. An
  // override set while `started` is n takes effect in update n + 1.
  std::uint64_t started = 0;
  std::uint64_t steps = 0;
};

class Server {
 public:
  static std::shared_ptr<Server> of(ln_client clnt);
  static void forget(ln_client clnt);

  explicit Server(ln_client clnt);
  ~Server();

  void add_block(const std::shared_ptr<BlockState>& block);
  void remove_block(const std::shared_ptr<BlockState>& block);
  void register_signals(BlockState& block, const ln_parameter_signal* signals, unsigned n_signals);
  void update(BlockState& block, const void* const* inputs, void* const* outputs, bool only_inputs);
  /// always_publish: the topic from registration on. Throws Failure.
  void publish_now(const std::shared_ptr<BlockState>& block) { ensure_topic(block); }
  void unregister(BlockState& block) {
    std::lock_guard<std::mutex> lock(mutex_);
    block.registered = false;
    block.signals.clear();
  }

 private:
  struct Deferred {  // sync handling: an override waiting for its block's step
    ln_service_request request;
    std::shared_ptr<BlockState> block;
    std::uint64_t target_step;  // answered once the block completed this update
    std::chrono::steady_clock::time_point deadline;
  };

  void start();
  void close();
  static int on_query(ln_client, ln_service_request req, void* self);
  static int on_query_dict(ln_client, ln_service_request req, void* self);
  static int on_override(ln_client, ln_service_request req, void* self);
  static int on_request_topic(ln_client, ln_service_request req, void* self);
  int override(ln_service_request req, ln_parameters_override_dict_single_t& data);
  /// Sets (`value`) or ends (nullopt) the override of `signal` and answers,
  /// with wait_step after the block's next step.
  int finish_override(ln_service_request req, ln_parameters_override_dict_single_t& data,
                      const std::shared_ptr<BlockState>& block, SignalState& signal,
                      std::optional<std::vector<std::uint8_t>> value, bool wait_step);
  /// Signals matching `patterns`, in registration order (mutex_ held).
  std::vector<std::pair<std::shared_ptr<BlockState>, SignalState*>> matching_locked(std::string_view patterns);
  static int respond_override(ln_service_request req, ln_parameters_override_dict_single_t& data,
                              const std::string& error);
  /// Publishes the block's topic unless it is already (not with mutex_
  /// held: asks the manager). Throws Failure.
  void ensure_topic(const std::shared_ptr<BlockState>& block);
  /// Writes the block's packet if someone wants it (update() thread).
  void publish_step(BlockState& block);
  int request_topic(ln_service_request req, ln_parameters_request_parameter_topic_t& data);

  const ln_client clnt_;
  std::string client_name_;
  const bool sync_;
  bool closed_ = false;
  std::mutex mutex_;
  std::condition_variable stepped_;
  std::vector<std::shared_ptr<BlockState>> blocks_;
  std::vector<Deferred> deferred_;
  ln_service services_[4] = {};
  std::mutex topics_mutex_;  // one topic set-up at a time
  // Handlers running: close() lets them answer before it ends the services
  // (ending them closes the callers' connections at once).
  int handlers_running_ = 0;
  std::condition_variable handlers_done_;

 public:
  /// Marks a handler as running for its whole lifetime.
  struct Handling {
    Server& server;
    explicit Handling(Server& s) : server(s) {
      std::lock_guard<std::mutex> lock(server.mutex_);
      ++server.handlers_running_;
    }
    ~Handling() {
      std::lock_guard<std::mutex> lock(server.mutex_);
      if (--server.handlers_running_ == 0) server.handlers_done_.notify_all();
    }
  };
};

// ------------------------------------------------------------- registry

namespace {

std::mutex& registry_mutex() {
  static std::mutex mutex;
  return mutex;
}
std::map<ln_client, std::weak_ptr<Server>>& registry() {
  static std::map<ln_client, std::weak_ptr<Server>> servers;
  return servers;
}

}  // namespace

std::shared_ptr<Server> Server::of(ln_client clnt) {
  std::lock_guard<std::mutex> lock(registry_mutex());
  if (std::shared_ptr<Server> server = registry()[clnt].lock()) return server;
  auto server = std::make_shared<Server>(clnt);
  server->start();
  registry()[clnt] = server;
  return server;
}

void Server::forget(ln_client clnt) {
  std::shared_ptr<Server> server;
  {
    std::lock_guard<std::mutex> lock(registry_mutex());
    const auto found = registry().find(clnt);
    if (found == registry().end()) return;
    server = found->second.lock();
    registry().erase(found);
  }
  if (server) server->close();
}

void client_closing(ln_client clnt) {
  Server::forget(clnt);
  forget_remote_state(clnt);
}

// ---------------------------------------------------------------- server

Server::Server(ln_client clnt) : clnt_(clnt), sync_(environment_flag("LN_PARAMETER_SYNC_HANDLING")) {}

Server::~Server() { close(); }

void Server::start() {
  char* name = nullptr;
  if (ln_client_get_name(clnt_, &name) != 0 || name == nullptr)
    throw Failure(LNE_CLIENT_NOT_INITIALIZED, "parameter block: the client has no name");
  client_name_ = name;
  struct Kind {
    const char* prefix;
    const char* interface;
    const char* signature;
    ln_service_handler handler;
  };
  const Kind kinds[4] = {
      {"ln.parameters.query.", "ln/parameters/query", LN_PARAMETERS_QUERY_SIGNATURE, &Server::on_query},
      {"ln.parameters.query_dict.", "ln/parameters/query_dict", LN_PARAMETERS_QUERY_DICT_SIGNATURE,
       &Server::on_query_dict},
      {"ln.parameters.override_dict_single.", "ln/parameters/override_dict_single",
       LN_PARAMETERS_OVERRIDE_DICT_SINGLE_SIGNATURE, &Server::on_override},
      {"ln.parameters.request_topic.", "ln/parameters/request_parameter_topic",
       LN_PARAMETERS_REQUEST_PARAMETER_TOPIC_SIGNATURE, &Server::on_request_topic},
  };
  auto check = [this](int ret, const std::string& what) {
    if (ret >= 0) return;
    const char* detail = ln_get_error_message(clnt_);
    const std::string text = "parameter services: " + what + ": " + (detail != nullptr ? detail : "");
    close();
    throw Failure(-ret, text);
  };
  for (int i = 0; i < 4; ++i) {
    const std::string service_name = kinds[i].prefix + client_name_;
    check(ln_service_init(clnt_, &services_[i], service_name.c_str(), kinds[i].interface, kinds[i].signature),
          service_name);
    check(ln_service_provider_set_handler(services_[i], kinds[i].handler, this), service_name);
    check(ln_service_provider_register_in_group(clnt_, services_[i], kGroup), "registering " + service_name);
  }
  if (!sync_) {
    check(ln_set_max_threads(clnt_, kPool, kPoolThreads), kPool);
    check(ln_handle_service_group_in_thread_pool(clnt_, kGroup, kPool), kPool);
  }
  debug_log(clnt_, "parameter services of '%s' registered; requests are handled %s", client_name_.c_str(),
            sync_ ? "inside update() (LN_PARAMETER_SYNC_HANDLING)" : "in the thread pool parameter_service_pool");
}

void Server::close() {
  std::vector<Deferred> deferred;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (closed_) return;
    closed_ = true;
    deferred.swap(deferred_);
  }
  stepped_.notify_all();
  for (Deferred& d : deferred) {
    ln_parameters_override_dict_single_t data{};
    respond_override(d.request, data, "the parameter provider is shutting down");
  }
  {
    // Handlers waiting for a step saw closed_ and answer now.
    std::unique_lock<std::mutex> lock(mutex_);
    handlers_done_.wait(lock, [this] { return handlers_running_ == 0; });
  }
  for (ln_service& service : services_)
    if (service != nullptr) ln_service_deinit(&service);
  std::lock_guard<std::mutex> topics(topics_mutex_);
  std::lock_guard<std::mutex> lock(mutex_);
  for (const auto& block : blocks_)
    if (block->topic && block->topic->port != nullptr) ln_unpublish(&block->topic->port);
}

void Server::add_block(const std::shared_ptr<BlockState>& block) {
  std::lock_guard<std::mutex> lock(mutex_);
  blocks_.push_back(block);
}

void Server::remove_block(const std::shared_ptr<BlockState>& block) {
  std::vector<Deferred> orphaned;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    block->closed = true;
    for (auto it = blocks_.begin(); it != blocks_.end();) it = (*it == block) ? blocks_.erase(it) : it + 1;
    for (auto it = deferred_.begin(); it != deferred_.end();) {
      if (it->block == block) {
        orphaned.push_back(*it);
        it = deferred_.erase(it);
      } else {
        ++it;
      }
    }
  }
  stepped_.notify_all();
  for (Deferred& d : orphaned) {
    ln_parameters_override_dict_single_t data{};
    respond_override(d.request, data, "parameter block '" + block->name + "' was destroyed before its next update");
  }
  std::lock_guard<std::mutex> topics(topics_mutex_);
  ln_outport port = nullptr;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (block->topic != nullptr && !closed_) std::swap(port, block->topic->port);
  }
  if (port != nullptr) ln_unpublish(&port);
}

void Server::register_signals(BlockState& block, const ln_parameter_signal* signals, unsigned n_signals) {
  if (signals == nullptr && n_signals > 0) throw Failure(LNE_INVALID_PARAMETER, "signals must not be NULL");
  std::vector<SignalState> states;
  for (unsigned i = 0; i < n_signals; ++i) {
    const ln_parameter_signal& s = signals[i];
    const std::string label = "parameter block '" + block.name + "', parameter " + std::to_string(i);
    if (s.name == nullptr || s.name[0] == '\0') throw Failure(LNE_INVALID_PARAMETER, label + ": the name is empty");
    SignalState state;
    state.full_name = block.name.empty() ? s.name : block.name + "." + s.name;
    const std::string who = "parameter '" + state.full_name + "'";
    const std::optional<ElementType> type = element_type_from_id(s.type);
    if (!type) throw Failure(LNE_INVALID_PARAMETER, who + ": unknown type id " + std::to_string(s.type) + " (0..10)");
    if (std::string error = check_dims(s.dims, s.n_dims); !error.empty())
      throw Failure(LNE_INVALID_PARAMETER, who + ": " + error);
    if (s.input == nullptr) throw Failure(LNE_INVALID_PARAMETER, who + ": the input pointer is NULL");
    state.description = s.description != nullptr ? s.description : "";
    state.type = *type;
    state.shape.dims.assign(s.dims, s.dims + s.n_dims);
    state.row_major = s.row_major != 0;
    state.input = s.input;
    state.output = s.output;
    state.before_update = s.before_update;
    state.after_update = s.after_update;
    state.user_data = s.user_data;
    state.input_value.resize(state.bytes());
    to_row_major(s.input, state.input_value.data(), state.type, state.shape, state.row_major);
    state.output_value = state.input_value;
    for (const SignalState& earlier : states)
      if (earlier.full_name == state.full_name)
        throw Failure(LNE_INVALID_PARAMETER, who + " is registered twice in this block");
    states.push_back(std::move(state));
  }
  std::lock_guard<std::mutex> lock(mutex_);
  if (closed_) throw Failure(LNE_CLIENT_NOT_INITIALIZED, "parameter block '" + block.name + "': the client is gone");
  if (block.registered)
    throw Failure(LNE_INVALID_PARAMETER, "parameter block '" + block.name + "' is registered already (once per block)");
  for (const SignalState& state : states)
    for (const auto& other : blocks_)
      if (other->registered)
        for (const SignalState& taken : other->signals)
          if (taken.full_name == state.full_name)
            throw Failure(LNE_INVALID_PARAMETER, "parameter '" + state.full_name + "' is provided by block '" +
                                                     other->name + "' of this client already");
  block.signals = std::move(states);
  block.registered = true;
  debug_log(clnt_, "parameter block '%s' registered %zu parameters", block.name.c_str(), block.signals.size());
}

void Server::ensure_topic(const std::shared_ptr<BlockState>& block) {
  std::lock_guard<std::mutex> topics(topics_mutex_);
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (block->topic != nullptr) return;
    if (closed_ || block->closed)
      throw Failure(LNE_CLIENT_NOT_INITIALIZED, "parameter block '" + block->name + "' is gone");
  }
  // The signals do not change once registered.
  std::vector<TopicField> fields;
  for (const SignalState& s : block->signals) fields.push_back(TopicField{s.full_name, s.type, s.shape.elements()});
  const TopicLayout layout = topic_layout(fields);
  const std::string who = "parameter block '" + block->name + "' cannot be published on a topic: ";
  if (!layout.error.empty()) throw Failure(LNE_INVALID_PARAMETER, who + layout.error);
  for (const auto& [name, text] : layout.definitions) {
    const int ret = ln_put_message_definition(clnt_, name.c_str(), text.c_str(), nullptr);
    if (ret < 0) throw Failure(-ret, who + ln_get_error_message(clnt_));
  }
  auto topic = std::make_unique<BlockTopic>();
  topic->name = block->topic_name.empty() ? client_name_ + "." + block->name : block->topic_name;
  topic->message_definition = layout.root;
  topic->order = layout.order;
  topic->packet.reserve(layout.packet_size);
  const int ret = ln_publish(clnt_, topic->name.c_str(), layout.root.c_str(), &topic->port);
  if (ret < 0) throw Failure(-ret, who + ln_get_error_message(clnt_));
  debug_log(clnt_, "parameter block '%s' publishes topic '%s' (%s)", block->name.c_str(), topic->name.c_str(),
            layout.root.c_str());
  std::lock_guard<std::mutex> lock(mutex_);
  block->topic = std::move(topic);
}

void Server::publish_step(BlockState& block) {
  ln_outport port = nullptr;
  std::vector<std::uint8_t>* packet = nullptr;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    BlockTopic* topic = block.topic.get();
    if (topic == nullptr || topic->port == nullptr || closed_) return;
    const bool requested = std::chrono::steady_clock::now() < topic->requested_until;
    if (!block.always_publish && !requested && ln_has_subscriber(topic->port) <= 0) return;
    topic->packet.clear();
    for (const std::size_t i : topic->order) {
      const SignalState& s = block.signals[i];
      append_to_packet(topic->packet, s.input_value, s.output_value, s.override_enabled);
    }
    port = topic->port;
    packet = &topic->packet;
  }
  // Only this thread (the block's update()) writes the packet buffer.
  ln_write(port, packet->data(), static_cast<unsigned>(packet->size()), nullptr);
}

void Server::update(BlockState& block, const void* const* inputs, void* const* outputs, bool only_inputs) {
  if (sync_) {
    const int ret = ln_wait_and_handle_service_group_requests(clnt_, kGroup, 0);
    if (ret < 0) throw Failure(-ret, "parameter block '" + block.name + "': handling parameter requests");
  }
  struct Applied {
    const SignalState* signal;
    void* program_value;                 // where the program sees the value, or
    std::vector<std::uint8_t> own_copy;  // a copy in its layout
  };
  std::vector<Applied> applied;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (closed_) throw Failure(LNE_CLIENT_NOT_INITIALIZED, "parameter block '" + block.name + "': the client is gone");
    if (!block.registered)
      throw Failure(LNE_INVALID_PARAMETER,
                    "parameter block '" + block.name + "': update() before register_parameters()");
    ++block.started;
    for (std::size_t i = 0; i < block.signals.size(); ++i) {
      SignalState& s = block.signals[i];
      const void* in = inputs != nullptr ? inputs[i] : s.input;
      if (in != nullptr) to_row_major(in, s.input_value.data(), s.type, s.shape, s.row_major);
      s.output_value = s.override_enabled ? s.override_value : s.input_value;
      void* out = only_inputs ? nullptr : outputs != nullptr ? outputs[i] : s.output;
      if (out != nullptr) from_row_major(s.output_value.data(), out, s.type, s.shape, s.row_major);
      if (s.override_enabled && s.apply_pending) {
        s.apply_pending = false;
        if (s.after_update != nullptr)
          applied.push_back(
              Applied{&s, out, out != nullptr ? std::vector<std::uint8_t>{} : s.program_layout(s.output_value)});
      }
    }
  }
  // Before the step counts as done, so that an override with wait_step
  // returns only once the program has seen it. The signals never change
  // after registration, and only this thread calls update().
  for (Applied& a : applied)
    a.signal->after_update(a.program_value != nullptr ? a.program_value : a.own_copy.data(), a.signal->user_data);

  std::vector<std::pair<ln_service_request, std::string>> answers;  // deferred overrides, with their error
  {
    std::lock_guard<std::mutex> lock(mutex_);
    ++block.steps;
    const auto now = std::chrono::steady_clock::now();
    for (auto it = deferred_.begin(); it != deferred_.end();) {
      if (it->block.get() == &block && block.steps >= it->target_step) {
        answers.emplace_back(it->request, "");
        it = deferred_.erase(it);
      } else if (now > it->deadline) {
        answers.emplace_back(it->request, no_step_error(it->block->name));
        it = deferred_.erase(it);
      } else {
        ++it;
      }
    }
  }
  stepped_.notify_all();
  for (const auto& [request, error] : answers) {
    ln_parameters_override_dict_single_t data{};
    respond_override(request, data, error);
  }
  publish_step(block);
}

std::vector<std::pair<std::shared_ptr<BlockState>, SignalState*>> Server::matching_locked(std::string_view patterns) {
  std::vector<std::pair<std::shared_ptr<BlockState>, SignalState*>> found;
  for (const auto& block : blocks_)
    if (block->registered)
      for (SignalState& s : block->signals)
        if (pattern_match(patterns, s.full_name)) found.emplace_back(block, &s);
  return found;
}

// -------------------------------------------------------------- handlers

namespace {

std::string_view request_text(const char* text, std::uint32_t len) {
  return text != nullptr ? std::string_view(text, len) : std::string_view();
}

}  // namespace

int Server::on_query(ln_client, ln_service_request req, void* self_) {
  ln_parameters_query_t data{};
  if (ln_service_request_set_data(req, &data, LN_PARAMETERS_QUERY_SIGNATURE) != 0) return -LNE_SVC_RECV_REQ;
  auto* self = static_cast<Server*>(self_);
  const Handling handling(*self);
  struct Row {
    std::string name, data_type;
    std::vector<std::uint8_t> output, input;
    bool override_enabled;
  };
  std::vector<Row> rows;
  {
    std::lock_guard<std::mutex> lock(self->mutex_);
    for (const auto& [block, s] : self->matching_locked(request_text(data.req.pattern, data.req.pattern_len))) {
      Row row{s->full_name, binary_type_string(s->type, s->shape), s->output_value, s->input_value,
              s->override_enabled};
      // The binary form carries matrices column-major.
      from_row_major(s->output_value.data(), row.output.data(), s->type, s->shape, false);
      from_row_major(s->input_value.data(), row.input.data(), s->type, s->shape, false);
      rows.push_back(std::move(row));
    }
  }
  std::vector<ln_parameters_value_t> values(rows.size());
  for (std::size_t i = 0; i < rows.size(); ++i) {
    Row& row = rows[i];
    ln_parameters_value_t& v = values[i];
    v.name_len = static_cast<std::uint32_t>(row.name.size());
    v.name = row.name.data();
    v.data_type_len = static_cast<std::uint32_t>(row.data_type.size());
    v.data_type = row.data_type.data();
    v.output_data_len = static_cast<std::uint32_t>(row.output.size());
    v.output_data = row.output.data();
    v.override_enabled = row.override_enabled ? 1 : 0;
    v.input_data_len = static_cast<std::uint32_t>(row.input.size());
    v.input_data = row.input.data();
  }
  data.resp.values_len = static_cast<std::uint32_t>(values.size());
  data.resp.values = values.data();
  return ln_service_request_respond(req);
}

int Server::on_query_dict(ln_client, ln_service_request req, void* self_) {
  ln_parameters_query_dict_t data{};
  if (ln_service_request_set_data(req, &data, LN_PARAMETERS_QUERY_DICT_SIGNATURE) != 0) return -LNE_SVC_RECV_REQ;
  auto* self = static_cast<Server*>(self_);
  const Handling handling(*self);
  std::string text = "{\n";
  {
    std::lock_guard<std::mutex> lock(self->mutex_);
    for (const auto& [block, s] : self->matching_locked(request_text(data.req.pattern, data.req.pattern_len))) {
      text += "  " + python_string_literal(s->full_name) +
              ": dict(input=" + format_value_for_display(s->type, s->shape, s->input_value.data()) +
              ", output=" + format_value_for_display(s->type, s->shape, s->output_value.data()) +
              ", override_enabled=" + (s->override_enabled ? "True" : "False") +
              ", description=" + python_string_literal(s->description) + "),\n";
    }
  }
  text += "}\n";
  data.resp.data_len = static_cast<std::uint32_t>(text.size());
  data.resp.data = text.data();
  return ln_service_request_respond(req);
}

int Server::respond_override(ln_service_request req, ln_parameters_override_dict_single_t& data,
                             const std::string& error) {
  std::string text = error;
  data.resp.error_len = static_cast<std::uint32_t>(text.size());
  data.resp.error = text.data();
  // Deferred requests were copied with set_data() before; respond_data
  // sends exactly this response.
  return ln_service_request_respond_data(req, &data);
}

int Server::on_override(ln_client, ln_service_request req, void* self_) {
  ln_parameters_override_dict_single_t data{};
  if (ln_service_request_set_data(req, &data, LN_PARAMETERS_OVERRIDE_DICT_SINGLE_SIGNATURE) != 0)
    return -LNE_SVC_RECV_REQ;
  // No owning reference here: the last one must not go in a handler
  // thread. ~Server waits in close() for running handlers, which see closed_.
  auto* self = static_cast<Server*>(self_);
  const Handling handling(*self);
  return self->override(req, data);
}

int Server::override(ln_service_request req, ln_parameters_override_dict_single_t& data) {
  const std::string name(request_text(data.req.parameter_name, data.req.parameter_name_len));
  const std::string text(request_text(data.req.override_data, data.req.override_data_len));
  const bool wait_step = data.req.wait_step != 0;

  std::shared_ptr<BlockState> block;
  SignalState* signal = nullptr;
  ElementType type = ElementType::Double;
  Shape shape;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    const auto found = matching_locked(name);
    if (found.empty())
      return respond_override(req, data, "no parameter '" + name + "' here (client '" + client_name_ + "')");
    if (found.size() > 1) {
      std::string names;
      for (const auto& f : found) names += (names.empty() ? "" : ", ") + f.second->full_name;
      return respond_override(
          req, data, "'" + name + "' matches " + std::to_string(found.size()) + " parameters, name one: " + names);
    }
    block = found[0].first;
    signal = found[0].second;
    type = signal->type;
    shape = signal->shape;
  }
  if (text.empty()) return finish_override(req, data, block, *signal, std::nullopt, wait_step);

  Literal literal;
  std::string error;
  if (!parse_literal(text, literal, error))
    return respond_override(req, data, "parameter '" + signal->full_name + "': cannot read '" + text + "': " + error);
  std::vector<std::uint8_t> value;
  error = literal_to_value(literal, type, shape, signal->full_name, value);
  if (!error.empty()) return respond_override(req, data, error);

  if (signal->before_update != nullptr) {
    std::vector<std::uint8_t> program_value(value.size());
    from_row_major(value.data(), program_value.data(), type, shape, signal->row_major);
    if (signal->before_update(program_value.data(), signal->user_data) == 0) {
      debug_log(clnt_, "override of '%s' with %s refused by its before_update check", signal->full_name.c_str(),
                text.c_str());
      return respond_override(
          req, data,
          "parameter '" + signal->full_name + "': the provider's check (before_update) refused the value " + text);
    }
    // The callback may have changed the value in place, as LN 2.9 lets it.
    to_row_major(program_value.data(), value.data(), type, shape, signal->row_major);
  }

  debug_log(clnt_, "override of '%s' set to %s", signal->full_name.c_str(), text.c_str());
  return finish_override(req, data, block, *signal, std::move(value), wait_step);
}

int Server::finish_override(ln_service_request req, ln_parameters_override_dict_single_t& data,
                            const std::shared_ptr<BlockState>& block, SignalState& signal,
                            std::optional<std::vector<std::uint8_t>> value, bool wait_step) {
  std::unique_lock<std::mutex> lock(mutex_);
  if (block->closed || closed_)
    return respond_override(req, data, "parameter block '" + block->name + "' was destroyed");
  if (value) {
    signal.override_value = *value;
    signal.output_value = std::move(*value);
    signal.override_enabled = true;
    signal.apply_pending = true;
  } else {
    // Ending an override: the output follows the input from the next step.
    signal.override_enabled = false;
    signal.apply_pending = false;
    debug_log(clnt_, "override of '%s' ended", signal.full_name.c_str());
  }
  if (!wait_step) {
    lock.unlock();
    return respond_override(req, data, "");
  }
  const std::uint64_t target = block->started + 1;
  if (sync_) {
    // This runs inside some block's update(); the target block's next
    // completed update answers.
    deferred_.push_back(Deferred{req, block, target, std::chrono::steady_clock::now() + kWaitStepTimeout});
    return -LNE_SVC_RESP_LATER;
  }
  const bool stepped =
      stepped_.wait_for(lock, kWaitStepTimeout, [&] { return block->steps >= target || block->closed || closed_; });
  const bool gone = block->closed || closed_;
  lock.unlock();
  if (gone)
    return respond_override(req, data, "parameter block '" + block->name + "' was destroyed before its next update");
  if (!stepped) return respond_override(req, data, no_step_error(block->name));
  return respond_override(req, data, "");
}

int Server::on_request_topic(ln_client, ln_service_request req, void* self_) {
  ln_parameters_request_parameter_topic_t data{};
  if (ln_service_request_set_data(req, &data, LN_PARAMETERS_REQUEST_PARAMETER_TOPIC_SIGNATURE) != 0)
    return -LNE_SVC_RECV_REQ;
  auto* self = static_cast<Server*>(self_);
  const Handling handling(*self);
  std::string error;
  try {
    return self->request_topic(req, data);
  } catch (const std::exception& e) {
    error = e.what();
  }
  data.resp.error_len = static_cast<std::uint32_t>(error.size());
  data.resp.error = error.data();
  return ln_service_request_respond(req);
}

int Server::request_topic(ln_service_request req, ln_parameters_request_parameter_topic_t& data) {
  // "a.b, a.c": LN 2.9 separates the names by ", ".
  std::vector<std::string> names;
  const std::string list(request_text(data.req.parameters, data.req.parameters_len));
  for (std::size_t start = 0; start <= list.size();) {
    std::size_t comma = list.find(',', start);
    if (comma == std::string::npos) comma = list.size();
    std::string name = list.substr(start, comma - start);
    name.erase(0, name.find_first_not_of(' '));
    name.erase(name.find_last_not_of(' ') + 1);
    if (!name.empty()) names.push_back(name);
    start = comma + 1;
  }
  std::string error;
  std::vector<std::pair<std::string, std::shared_ptr<BlockState>>> wanted;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (names.empty()) error = "no parameter names given ('" + list + "')";
    for (const std::string& name : names) {
      const auto found = matching_locked(name);
      if (found.size() != 1) {
        error = found.empty() ? "no parameter '" + name + "' here (client '" + client_name_ + "')"
                              : "'" + name + "' matches " + std::to_string(found.size()) + " parameters";
        break;
      }
      wanted.emplace_back(found[0].second->full_name, found[0].first);
    }
  }
  std::string text = "{\n";
  if (error.empty()) {
    for (const auto& [name, block] : wanted) ensure_topic(block);  // throws with a message
    std::lock_guard<std::mutex> lock(mutex_);
    for (const auto& [name, block] : wanted) {
      block->topic->requested_until = std::chrono::steady_clock::now() + kTopicRequestLifetime;
      text += "  " + python_string_literal(name) + ": (" + python_string_literal(block->topic->name) + ", " +
              python_string_literal(block->topic->message_definition) + "),\n";
    }
  }
  text += "}\n";
  if (!error.empty()) text.clear();
  data.resp.parameter_topics_len = static_cast<std::uint32_t>(text.size());
  data.resp.parameter_topics = text.data();
  data.resp.error_len = static_cast<std::uint32_t>(error.size());
  data.resp.error = error.data();
  return ln_service_request_respond(req);
}

// ----------------------------------------------------------------- block

Block::Block(ln_client clnt, const char* group_name, bool always_publish, const char* topic_name)
    : server_(Server::of(clnt)), state_(std::make_shared<BlockState>()) {
  const char* prefix = std::getenv("LN_PARAMETER_PREFIX");
  state_->name = std::string(prefix != nullptr ? prefix : "") + (group_name != nullptr ? group_name : "");
  state_->always_publish = always_publish;
  state_->topic_name = topic_name != nullptr ? topic_name : "";
  server_->add_block(state_);
}

Block::~Block() { server_->remove_block(state_); }

void Block::register_signals(const ln_parameter_signal* signals, unsigned n_signals) {
  server_->register_signals(*state_, signals, n_signals);
  if (!state_->always_publish) return;
  try {
    server_->publish_now(state_);
  } catch (...) {
    server_->unregister(*state_);  // all or nothing
    throw;
  }
}

void Block::update(const void* const* inputs, void* const* outputs, bool only_inputs) {
  server_->update(*state_, inputs, outputs, only_inputs);
}

const std::string& Block::name() const { return state_->name; }

}  // namespace ln::paramcore
