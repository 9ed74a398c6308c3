#include "bridge/topic_paths.hpp"

#include <chrono>
#include <cstdio>
#include <cstring>
#include <stdexcept>
#include <utility>

namespace msg_mapping::bridge {
namespace {

double monotonic_seconds() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

std::string hex(const Gid& gid) {
  std::string out;
  char byte[3];
  for (std::uint8_t b : gid) {
    std::snprintf(byte, sizeof byte, "%02x", b);
    out += byte;
  }
  return out;
}

Gid gid_of(const std::uint8_t* data) {
  Gid gid;
  std::memcpy(gid.data(), data, gid.size());
  return gid;
}

static_assert(RMW_GID_STORAGE_SIZE == std::tuple_size<Gid>::value, "Gid must hold an rmw gid");

constexpr double read_slice = 0.5;   // seconds a blocked LN read waits before checking for close()
constexpr double idle_wake = 0.25;   // seconds between takes without a new-message event (a missed one)
constexpr double held_wake = 0.05;   // ... while messages wait for the graph to name their publisher
constexpr double refresh_period = 1.0;  // seconds between graph look-ups that forget departed publishers

}  // namespace

// ------------------------------------------------------------------ codec

std::size_t TopicCodec::to_cdr(Bytes ln, std::vector<std::uint8_t>& out) const {
  if (rule_) {
    out = rule_->ln_to_cdr(ln);
    return out.size();
  }
  const std::size_t size = codec_->fixed_cdr_size() ? codec_->fixed_cdr_size() : codec_->cdr_size(ln);
  if (out.size() < size) out.resize(size);
  return codec_->ln_to_cdr(ln, {out.data(), size});
}

void TopicCodec::to_ln(Bytes cdr, MutableBytes packet) const {
  if (rule_) {
    const std::vector<std::uint8_t> ln = rule_->cdr_to_ln(cdr);
    if (ln.size() != packet.size) throw CodecError("rule produced " + std::to_string(ln.size()) + " bytes");
    std::memcpy(packet.data, ln.data(), ln.size());
    return;
  }
  codec_->cdr_to_ln(cdr, packet);
}

// ------------------------------------------------------------------ state

void PathState::error(const std::string& text) {
  ++errors;
  std::lock_guard<std::mutex> lock(mutex_);
  ++new_errors_;
  last_error_ = text;
}

void PathState::fail(const std::string& text) {
  std::lock_guard<std::mutex> lock(mutex_);
  failure_ = text;
  failed_ = true;
}

void PathState::nodeless(const std::string& gid_hex) {
  std::lock_guard<std::mutex> lock(mutex_);
  nodeless_.push_back(gid_hex);
}

PathReport PathState::report() {
  PathReport r;
  r.received = received;
  r.forwarded = forwarded;
  r.errors = errors;
  r.lost = lost;
  r.ignored = ignored;
  r.held = held;
  std::lock_guard<std::mutex> lock(mutex_);
  r.error_count_in_text = std::exchange(new_errors_, 0);
  r.errors_text = std::exchange(last_error_, {});
  r.nodeless = std::exchange(nodeless_, {});
  r.failed = failed_;
  r.failure = failure_;
  return r;
}

// ------------------------------------------------------------------ LN client

LnClient::LnClient(const LnApi& api, ln_client handle) : api_(api), handle_(handle) {
  if (!handle_) throw std::invalid_argument("LN client handle is NULL");
}

LnClient::LnClient(const LnApi& api, const std::string& name, const std::string& manager) : api_(api), owned_(true) {
  const int ret = api_.init_to_manager(&handle_, name.c_str(), manager.empty() ? nullptr : manager.c_str());
  if (ret < 0) throw std::runtime_error(api_.error("cannot connect LN client '" + name + "'", ret));
}

LnClient::~LnClient() { close(); }

void LnClient::close() {
  if (owned_ && handle_) api_.deinit(&handle_);
  handle_ = nullptr;
}

std::string LnClient::name() const {
  char* name = nullptr;
  if (!handle_ || api_.client_get_name(handle_, &name) < 0 || !name) return {};
  return name;
}

// ------------------------------------------------------------------ LN -> ROS

LnToRosPath::LnToRosPath(const LnClient& client, const std::string& topic, const std::string& md_name,
                         const LnPortOptions& options, TopicCodec codec, rcl_publisher_t* publisher)
    : ln_(client.api()), rcl_(RclApi::loaded()), codec_(codec), publisher_(publisher) {
  if (!client.handle()) throw std::runtime_error("the LN client is closed");
  const int ret = ln_.subscribe(client.handle(), topic.c_str(), md_name.c_str(), &port_, options.rate,
                                options.reliable_transport ? 1 : 0, options.buffers);
  if (ret < 0) throw std::runtime_error(ln_.error("cannot subscribe LN topic " + topic, ret));
  size_ = static_cast<std::size_t>(ln_.message_size(port_));
  if (size_ != codec_.ln_size()) {
    ln_.unsubscribe(&port_);
    throw std::runtime_error("LN topic " + topic + " carries " + std::to_string(size_) + "-byte packets but " +
                             md_name + " is " + std::to_string(codec_.ln_size()) + " bytes: the definitions differ");
  }
  thread_ = std::thread(&LnToRosPath::run, this);
}

LnToRosPath::~LnToRosPath() { close(); }

void LnToRosPath::close() {
  if (!port_) return;
  stop_ = true;
  ln_.unblock(port_);
  if (thread_.joinable()) thread_.join();
  ln_.unsubscribe(&port_);
  port_ = nullptr;
}

void LnToRosPath::run() {
  std::vector<std::uint8_t> packet(size_), cdr;
  rcl_serialized_message_t message{};  // (zero-initialized: no library call)
  while (!stop_) {
    const void* data = packet.data();
    unsigned int size = static_cast<unsigned int>(size_);
    ln_sample_info info{};
    double timestamp = 0;
    const bool borrowing = ln_.read_borrow != nullptr;  // ln_core: the packet in place, no copy
    const int ret = borrowing ? ln_.read_borrow(port_, &data, &size, &info, read_slice)
                              : ln_.read_timeout(port_, packet.data(), size, &timestamp, read_slice);
    if (ret == 0 || (ret == -LNE_PORT_UNBLOCKED && !stop_)) continue;
    if (ret < 0) {
      if (!stop_) state_.fail(ln_.error("LN read", ret));
      break;
    }
    ++state_.received;
    state_.lost += info.lost;
    std::size_t cdr_size = 0;
    try {
      cdr_size = codec_.to_cdr({static_cast<const std::uint8_t*>(data), size}, cdr);
    } catch (const std::exception& e) {
      state_.error(e.what());
    }
    if (borrowing) ln_.read_release(port_);
    if (!cdr_size) continue;
    message.buffer = cdr.data();
    message.buffer_length = cdr_size;
    message.buffer_capacity = cdr.size();
    const rcl_ret_t published = rcl_.publish_serialized(publisher_, &message, nullptr);
    if (published == RCL_RET_OK) ++state_.forwarded;
    else state_.error(rcl_.error("publish", published));
  }
}

// ------------------------------------------------------------------ ROS -> LN

namespace {

rmw_qos_profile_t qos_profile(const RclApi& rcl, const RosQos& qos) {
  rmw_qos_profile_t profile = rcl.subscription_default_options().qos;
  if (qos.reliability == "reliable") profile.reliability = RMW_QOS_POLICY_RELIABILITY_RELIABLE;
  else if (qos.reliability == "best_effort") profile.reliability = RMW_QOS_POLICY_RELIABILITY_BEST_EFFORT;
  else if (qos.reliability == "best_available") profile.reliability = RMW_QOS_POLICY_RELIABILITY_BEST_AVAILABLE;
  else throw std::invalid_argument("unknown reliability '" + qos.reliability + "'");
  if (qos.durability == "volatile") profile.durability = RMW_QOS_POLICY_DURABILITY_VOLATILE;
  else if (qos.durability == "transient_local") profile.durability = RMW_QOS_POLICY_DURABILITY_TRANSIENT_LOCAL;
  else if (qos.durability == "best_available") profile.durability = RMW_QOS_POLICY_DURABILITY_BEST_AVAILABLE;
  else throw std::invalid_argument("unknown durability '" + qos.durability + "'");
  if (qos.history == "keep_last") profile.history = RMW_QOS_POLICY_HISTORY_KEEP_LAST;
  else if (qos.history == "keep_all") profile.history = RMW_QOS_POLICY_HISTORY_KEEP_ALL;
  else throw std::invalid_argument("unknown history '" + qos.history + "'");
  profile.depth = qos.depth;
  return profile;
}

}  // namespace

RosToLnPath::RosToLnPath(const LnClient& client, const std::string& topic, const std::string& md_name,
                         unsigned int buffers, TopicCodec codec, rcl_node_t* node,
                         const rosidl_message_type_support_t* type_support, const std::string& ros_topic,
                         const RosQos& qos, std::vector<std::string> bridge_names)
    : ln_(client.api()),
      rcl_(RclApi::loaded()),
      codec_(codec),
      node_(node),
      subscription_(rcl_.zero_subscription()),
      bridge_names_(std::move(bridge_names)),
      senders_([this] { return publishers(); },
               [this](const std::string& n) { return matches_any(n, bridge_names_); }, qos.depth) {
  if (!client.handle()) throw std::runtime_error("the LN client is closed");
  int ret = ln_.publish(client.handle(), topic.c_str(), md_name.c_str(), buffers, &port_);
  if (ret < 0) throw std::runtime_error(ln_.error("cannot publish LN topic " + topic, ret));
  packet_.resize(static_cast<std::size_t>(ln_.message_size(port_)));
  if (packet_.size() != codec_.ln_size()) {
    ln_.unpublish(&port_);
    throw std::runtime_error("LN topic " + topic + " carries " + std::to_string(packet_.size()) + "-byte packets but " +
                             md_name + " is " + std::to_string(codec_.ln_size()) + " bytes: the definitions differ");
  }
  rcl_subscription_options_t options = rcl_.subscription_default_options();
  try {
    options.qos = qos_profile(rcl_, qos);
  } catch (...) {
    ln_.unpublish(&port_);
    throw;
  }
  ret = rcl_.subscription_init(&subscription_, node_, type_support, ros_topic.c_str(), &options);
  if (ret != RCL_RET_OK) {
    const std::string text = rcl_.error("cannot subscribe ROS topic " + ros_topic, ret);
    ln_.unpublish(&port_);
    throw std::runtime_error(text);
  }
  ros_topic_ = rcl_.subscription_topic_name(&subscription_);
  thread_ = std::thread(&RosToLnPath::run, this);
  ret = rcl_.set_on_new_message_callback(&subscription_, &RosToLnPath::on_new_message, this);
  if (ret != RCL_RET_OK) {
    const std::string text = rcl_.error("ROS topic " + ros_topic_ + ": no new-message events", ret);
    close();
    throw std::runtime_error(text);
  }
}

RosToLnPath::~RosToLnPath() { close(); }

void RosToLnPath::on_new_message(const void* self, std::size_t count) {
  auto* path = const_cast<RosToLnPath*>(static_cast<const RosToLnPath*>(self));
  {
    std::lock_guard<std::mutex> lock(path->wake_mutex_);
    path->unread_ += count;
  }
  path->wake_.notify_one();
}

void RosToLnPath::close() {
  if (!port_) return;
  // After this returns the middleware no longer calls on_new_message.
  if (rcl_.set_on_new_message_callback(&subscription_, nullptr, nullptr) != RCL_RET_OK) rcl_.reset_error();
  {
    std::lock_guard<std::mutex> lock(wake_mutex_);
    stop_ = true;
  }
  wake_.notify_one();
  if (thread_.joinable()) thread_.join();
  if (rcl_.subscription_fini(&subscription_, node_) != RCL_RET_OK) rcl_.reset_error();
  ln_.unpublish(&port_);
  port_ = nullptr;
}

std::vector<Endpoint> RosToLnPath::publishers() const {
  std::vector<Endpoint> out;
  rcutils_allocator_t allocator = rcl_.default_allocator();
  rmw_topic_endpoint_info_array_t info{};
  if (rcl_.publishers_info_by_topic(node_, &allocator, ros_topic_.c_str(), false, &info) != RCL_RET_OK) {
    rcl_.reset_error();
    return out;
  }
  for (std::size_t i = 0; i < info.size; ++i) {
    const rmw_topic_endpoint_info_t& e = info.info_array[i];
    Endpoint endpoint;
    endpoint.gid = gid_of(e.endpoint_gid);
    const std::string name = e.node_name ? e.node_name : "";
    if (!name.empty() && name != "_NODE_NAME_UNKNOWN_") {
      std::string space = e.node_namespace ? e.node_namespace : "";
      while (!space.empty() && space.back() == '/') space.pop_back();
      endpoint.node = space + "/" + name;
    }
    out.push_back(std::move(endpoint));
  }
  if (rcl_.endpoint_info_array_fini(&info, &allocator) != RMW_RET_OK) rcl_.reset_error();
  return out;
}

void RosToLnPath::run() {
  rcl_serialized_message_t message{};  // (zero-initialized: no library call)
  rcutils_allocator_t allocator = rcl_.default_allocator();
  if (rcl_.uint8_array_init(&message, 4096, &allocator) != RCUTILS_RET_OK) {
    state_.fail("cannot allocate the message buffer");
    return;
  }
  double refreshed_at = monotonic_seconds();
  for (;;) {
    {
      std::unique_lock<std::mutex> lock(wake_mutex_);
      const double wait = senders_.has_held() ? held_wake : idle_wake;
      wake_.wait_for(lock, std::chrono::duration<double>(wait), [this] { return unread_ > 0 || stop_; });
      if (stop_) break;
      unread_ = 0;
    }
    // Take everything there is: events may be coalesced or (rarely) missed.
    for (int taken = 0; !stop_; ++taken) {
      rmw_message_info_t info{};
      const rcl_ret_t ret = rcl_.take_serialized(&subscription_, &message, &info, nullptr);
      if (ret == RCL_RET_SUBSCRIPTION_TAKE_FAILED) break;
      if (ret != RCL_RET_OK) {
        state_.error(rcl_.error("take", ret));
        break;
      }
      ++state_.received;
      process(message.buffer, message.buffer_length, info);
    }
    const double now = monotonic_seconds();
    const bool refresh = now - refreshed_at >= refresh_period;
    if (refresh) refreshed_at = now;
    if (senders_.has_held() || refresh) {
      for (const HeldMessage& m : senders_.release(now, refresh)) write(m.cdr.data(), m.cdr.size(), m.source_timestamp);
      for (const Gid& gid : senders_.take_nodeless()) state_.nodeless(hex(gid));
      state_.ignored = senders_.dropped();
      state_.held = senders_.held_count();
    }
  }
  if (rcl_.uint8_array_fini(&message) != RCUTILS_RET_OK) rcl_.reset_error();
}

void RosToLnPath::process(const std::uint8_t* cdr, std::size_t size, const rmw_message_info_t& info) {
  const Gid gid = gid_of(info.publisher_gid.data);
  const std::uint64_t sequence = info.publication_sequence_number;
  if (sequence != RMW_MESSAGE_INFO_SEQUENCE_NUMBER_UNSUPPORTED && sequence != 0) {
    auto [last, added] = last_sequence_.try_emplace(gid, sequence);
    if (!added) {
      if (sequence > last->second + 1) state_.lost += sequence - last->second - 1;
      last->second = std::max(last->second, sequence);
    }
  }
  const double now = monotonic_seconds();
  const SenderFilter::Decision decision = senders_.decide(gid, now);
  if (decision == SenderFilter::Decision::Hold) {
    senders_.hold(gid, HeldMessage{std::vector<std::uint8_t>(cdr, cdr + size), info.source_timestamp}, now);
  }
  if (senders_.has_held()) {
    for (const HeldMessage& m : senders_.release(now, false)) write(m.cdr.data(), m.cdr.size(), m.source_timestamp);
  }
  if (decision == SenderFilter::Decision::Forward) write(cdr, size, info.source_timestamp);
  state_.ignored = senders_.dropped();
  state_.held = senders_.held_count();
}

void RosToLnPath::write(const std::uint8_t* cdr, std::size_t size, std::int64_t source_timestamp) {
  try {
    codec_.to_ln({cdr, size}, {packet_.data(), packet_.size()});
  } catch (const std::exception& e) {
    state_.error(e.what());
    return;
  }
  double stamp = static_cast<double>(source_timestamp) / 1e9;
  const int ret = ln_.write(port_, packet_.data(), static_cast<unsigned int>(packet_.size()),
                            source_timestamp ? &stamp : nullptr);
  if (ret < 0) state_.error(ln_.error("LN write", ret));
  else ++state_.forwarded;
}

}  // namespace msg_mapping::bridge
