#include "bridge/topic_paths.hpp"

#include <algorithm>
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

constexpr double read_slice = 0.5;      // seconds a blocked LN read waits before checking for close()
constexpr double group_slice = 0.05;    // seconds the shared LN reader sleeps before taking new ports
constexpr double held_wake = 0.05;      // seconds between graph look-ups while messages wait for one
constexpr double refresh_period = 1.0;  // seconds between graph look-ups that forget departed publishers
// Packets one pump() forwards at most before it returns: a port that always has a packet (LN 2.9
// re-reads its ring after its manager restarted) must not keep close() and new ports waiting.
constexpr int pump_batch = 256;

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
  {
    std::lock_guard<std::mutex> lock(readers_mutex_);
    readers_.reset();
  }
  if (owned_ && handle_) api_.deinit(&handle_);
  handle_ = nullptr;
}

LnReaderGroup& LnClient::readers() {
  std::lock_guard<std::mutex> lock(readers_mutex_);
  if (!handle_) throw std::runtime_error("the LN client is closed");
  if (!readers_) readers_ = std::make_unique<LnReaderGroup>(api_, handle_);
  return *readers_;
}

std::string LnClient::name() const {
  char* name = nullptr;
  if (!handle_ || api_.client_get_name(handle_, &name) < 0 || !name) return {};
  return name;
}

// ------------------------------------------------------------------ LN -> ROS

LnToRosPath::LnToRosPath(LnClient& client, const std::string& topic, const std::string& md_name,
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
  packet_.resize(size_);
  try {
    if (size_ < own_thread_above) {
      group_ = &client.readers();
      group_->add(this);
    } else {
      thread_ = std::thread(&LnToRosPath::run, this);
    }
  } catch (...) {
    ln_.unsubscribe(&port_);
    throw;
  }
}

LnToRosPath::~LnToRosPath() { close(); }

void LnToRosPath::close() {
  if (!port_) return;
  stop_ = true;
  if (group_) {
    group_->remove(this);
  } else {
    ln_.unblock(port_);
    if (thread_.joinable()) thread_.join();
  }
  ln_.unsubscribe(&port_);
  port_ = nullptr;
}

void LnToRosPath::run() {
  while (!stop_ && pump(read_slice)) {
  }
}

bool LnToRosPath::pump(double timeout) {
  rcl_serialized_message_t message{};  // (zero-initialized: no library call)
  for (int batch = 0; batch < pump_batch; ++batch, timeout = 0) {
    const void* data = packet_.data();
    unsigned int size = static_cast<unsigned int>(size_);
    ln_sample_info info{};
    double timestamp = 0;
    const bool borrowing = ln_.read_borrow != nullptr;  // ln_core: the packet in place, no copy
    const int ret = borrowing ? ln_.read_borrow(port_, &data, &size, &info, timeout)
                              : ln_.read_timeout(port_, packet_.data(), size, &timestamp, timeout);
    if (ret == 0 || (ret == -LNE_PORT_UNBLOCKED && !stop_)) return true;
    if (ret < 0) {
      if (stop_) return false;
      state_.fail(ln_.error("LN read", ret));
      return false;
    }
    ++state_.received;
    state_.lost += info.lost;
    std::size_t cdr_size = 0;
    try {
      cdr_size = codec_.to_cdr({static_cast<const std::uint8_t*>(data), size}, cdr_);
    } catch (const std::exception& e) {
      state_.error(e.what());
    }
    if (borrowing) ln_.read_release(port_);
    if (!cdr_size) continue;
    message.buffer = cdr_.data();
    message.buffer_length = cdr_size;
    message.buffer_capacity = cdr_.size();
    const rcl_ret_t published = rcl_.publish_serialized(publisher_, &message, nullptr);
    if (published == RCL_RET_OK)
      ++state_.forwarded;
    else
      state_.error(rcl_.error("publish", published));
  }
  return true;
}

// ------------------------------------------------------------------ shared LN reader

LnReaderGroup::LnReaderGroup(const LnApi& api, ln_client client) : api_(api), client_(client) {
  thread_ = std::thread(&LnReaderGroup::run, this);
}

LnReaderGroup::~LnReaderGroup() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
  }
  changed_.notify_all();
  if (thread_.joinable()) thread_.join();
}

void LnReaderGroup::add(LnToRosPath* path) { request(path, true); }
void LnReaderGroup::remove(LnToRosPath* path) { request(path, false); }

void LnReaderGroup::request(LnToRosPath* path, bool add) {
  std::unique_lock<std::mutex> lock(mutex_);
  if (!failure_.empty()) {
    if (add) throw std::runtime_error(failure_);
    return;
  }
  requests_.emplace_back(path, add);
  const std::uint64_t ticket = ++requested_;
  changed_.notify_all();
  // The thread applies requests between waits of at most group_slice.
  changed_.wait(lock, [&] { return applied_ >= ticket || stop_ || !failure_.empty(); });
  if (add && !failure_.empty()) throw std::runtime_error(failure_);
}

void LnReaderGroup::run() {
  ln_multi_waiter waiter = nullptr;
  const int made = api_.multi_waiter_init(client_, &waiter);
  std::vector<LnToRosPath*> paths;
  std::unique_lock<std::mutex> lock(mutex_);
  if (made < 0) {
    failure_ = api_.error("cannot make an LN multi-waiter", made);
    changed_.notify_all();
    return;
  }
  while (!stop_) {
    for (auto& [path, add] : requests_) {
      if (add) {
        api_.multi_waiter_add(waiter, path->port_);
        paths.push_back(path);
      } else {
        api_.multi_waiter_remove(waiter, path->port_);
        paths.erase(std::remove(paths.begin(), paths.end(), path), paths.end());
      }
    }
    applied_ += requests_.size();
    requests_.clear();
    changed_.notify_all();
    if (paths.empty()) {
      changed_.wait(lock, [this] { return stop_ || !requests_.empty(); });
      continue;
    }
    lock.unlock();
    std::vector<LnToRosPath*> failed;
    if (api_.multi_waiter_wait(waiter, group_slice) > 0) {
      for (LnToRosPath* path : paths)
        if (api_.multi_waiter_can_read(waiter, path->port_) > 0 && !path->pump(0)) failed.push_back(path);
    }
    lock.lock();
    for (LnToRosPath* path : failed) {  // (the bridge closes it soon; meanwhile its port must not wake us)
      api_.multi_waiter_remove(waiter, path->port_);
      paths.erase(std::remove(paths.begin(), paths.end(), path), paths.end());
    }
  }
  for (LnToRosPath* path : paths) api_.multi_waiter_remove(waiter, path->port_);
  api_.multi_waiter_deinit(&waiter);
}

// ------------------------------------------------------------------ ROS -> LN

namespace {

rmw_qos_profile_t qos_profile(const RclApi& rcl, const RosQos& qos) {
  rmw_qos_profile_t profile = rcl.subscription_default_options().qos;
  if (qos.reliability == "reliable")
    profile.reliability = RMW_QOS_POLICY_RELIABILITY_RELIABLE;
  else if (qos.reliability == "best_effort")
    profile.reliability = RMW_QOS_POLICY_RELIABILITY_BEST_EFFORT;
  else if (qos.reliability == "best_available")
    profile.reliability = RMW_QOS_POLICY_RELIABILITY_BEST_AVAILABLE;
  else
    throw std::invalid_argument("unknown reliability '" + qos.reliability + "'");
  if (qos.durability == "volatile")
    profile.durability = RMW_QOS_POLICY_DURABILITY_VOLATILE;
  else if (qos.durability == "transient_local")
    profile.durability = RMW_QOS_POLICY_DURABILITY_TRANSIENT_LOCAL;
  else if (qos.durability == "best_available")
    profile.durability = RMW_QOS_POLICY_DURABILITY_BEST_AVAILABLE;
  else
    throw std::invalid_argument("unknown durability '" + qos.durability + "'");
  if (qos.history == "keep_last")
    profile.history = RMW_QOS_POLICY_HISTORY_KEEP_LAST;
  else if (qos.history == "keep_all")
    profile.history = RMW_QOS_POLICY_HISTORY_KEEP_ALL;
  else
    throw std::invalid_argument("unknown history '" + qos.history + "'");
  profile.depth = qos.depth;
  return profile;
}

}  // namespace

RosToLnPath::RosToLnPath(LnClient& client, const std::string& topic, const std::string& md_name, unsigned int buffers,
                         TopicCodec codec, rcl_node_t* node, const rosidl_message_type_support_t* type_support,
                         const std::string& ros_topic, const RosQos& qos, std::vector<std::string> bridge_names)
    : ln_(client.api()),
      rcl_(RclApi::loaded()),
      codec_(codec),
      node_(node),
      subscription_(rcl_.zero_subscription()),
      bridge_names_(std::move(bridge_names)),
      senders_([this](const std::string& n) { return matches_any(n, bridge_names_); }, qos.depth) {
  if (!client.handle()) throw std::runtime_error("the LN client is closed");
  rcutils_allocator_t allocator = rcl_.default_allocator();
  if (rcl_.uint8_array_init(&message_, 4096, &allocator) != RCUTILS_RET_OK)
    throw std::runtime_error(rcl_.error("cannot allocate a message buffer", RCL_RET_BAD_ALLOC));
  int ret = ln_.publish(client.handle(), topic.c_str(), md_name.c_str(), buffers, &port_);
  if (ret < 0) {
    release_buffer();
    throw std::runtime_error(ln_.error("cannot publish LN topic " + topic, ret));
  }
  packet_.resize(static_cast<std::size_t>(ln_.message_size(port_)));
  std::string problem;
  rcl_subscription_options_t options = rcl_.subscription_default_options();
  if (packet_.size() != codec_.ln_size()) {
    problem = "LN topic " + topic + " carries " + std::to_string(packet_.size()) + "-byte packets but " + md_name +
              " is " + std::to_string(codec_.ln_size()) + " bytes: the definitions differ";
  } else {
    try {
      options.qos = qos_profile(rcl_, qos);
      ret = rcl_.subscription_init(&subscription_, node_, type_support, ros_topic.c_str(), &options);
      if (ret != RCL_RET_OK) problem = rcl_.error("cannot subscribe ROS topic " + ros_topic, ret);
    } catch (const std::exception& e) {
      problem = e.what();
    }
  }
  if (!problem.empty()) {
    ln_.unpublish(&port_);
    release_buffer();
    throw std::runtime_error(problem);
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

void RosToLnPath::release_buffer() {
  if (message_.buffer && rcl_.uint8_array_fini(&message_) != RCUTILS_RET_OK) rcl_.reset_error();
}

void RosToLnPath::wake() {
  {
    std::lock_guard<std::mutex> lock(wake_mutex_);
    wake_flag_ = true;
  }
  wake_.notify_one();
}

void RosToLnPath::on_new_message(const void* self, std::size_t) {
  auto* path = const_cast<RosToLnPath*>(static_cast<const RosToLnPath*>(self));
  bool held = false;
  {
    std::lock_guard<std::mutex> lock(path->take_mutex_);
    path->drain();
    held = path->senders_.has_held();
  }
  if (held) path->wake();  // a publisher the path does not know: its thread asks the graph
}

void RosToLnPath::close() {
  if (!port_) return;
  // After this returns the middleware no longer calls on_new_message.
  if (rcl_.set_on_new_message_callback(&subscription_, nullptr, nullptr) != RCL_RET_OK) rcl_.reset_error();
  stop_ = true;
  wake();
  if (thread_.joinable()) thread_.join();
  if (rcl_.subscription_fini(&subscription_, node_) != RCL_RET_OK) rcl_.reset_error();
  ln_.unpublish(&port_);
  port_ = nullptr;
  release_buffer();
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
  double refreshed_at = -refresh_period;
  while (!stop_) {
    {
      std::unique_lock<std::mutex> lock(wake_mutex_);
      const double wait = senders_held_ ? held_wake : refresh_period;
      wake_.wait_for(lock, std::chrono::duration<double>(wait), [this] { return wake_flag_ || stop_.load(); });
      wake_flag_ = false;
    }
    if (stop_) break;
    // The graph is asked without take_mutex_: the middleware's thread may be
    // waiting for it in on_new_message, holding locks of its own.
    const std::vector<Endpoint> graph = publishers();
    double now = monotonic_seconds();
    const bool refresh = now - refreshed_at >= refresh_period;
    if (refresh) refreshed_at = now;
    std::lock_guard<std::mutex> lock(take_mutex_);
    senders_.learn(graph, refresh);
    now = monotonic_seconds();
    for (const HeldMessage& m : senders_.release(now)) write(m.cdr.data(), m.cdr.size(), m.source_timestamp);
    for (const Gid& gid : senders_.take_nodeless()) state_.nodeless(hex(gid));
    state_.ignored = senders_.dropped();
    state_.held = senders_.held_count();
    senders_held_ = senders_.has_held();
  }
}

void RosToLnPath::drain() {
  for (;;) {
    rmw_message_info_t info{};
    const rcl_ret_t ret = rcl_.take_serialized(&subscription_, &message_, &info, nullptr);
    if (ret == RCL_RET_SUBSCRIPTION_TAKE_FAILED) return;
    if (ret != RCL_RET_OK) {
      state_.error(rcl_.error("take", ret));
      return;
    }
    ++state_.received;
    process(message_.buffer, message_.buffer_length, info);
  }
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
  switch (senders_.decide(gid)) {
    case SenderFilter::Decision::Forward:
      write(cdr, size, info.source_timestamp);
      break;
    case SenderFilter::Decision::Drop:
      state_.ignored = senders_.dropped();
      break;
    case SenderFilter::Decision::Hold:
      senders_.hold(gid, HeldMessage{std::vector<std::uint8_t>(cdr, cdr + size), info.source_timestamp},
                    monotonic_seconds());
      state_.held = senders_.held_count();
      senders_held_ = true;
      break;
  }
}

void RosToLnPath::write(const std::uint8_t* cdr, std::size_t size, std::int64_t source_timestamp) {
  try {
    codec_.to_ln({cdr, size}, {packet_.data(), packet_.size()});
  } catch (const std::exception& e) {
    state_.error(e.what());
    return;
  }
  double stamp = static_cast<double>(source_timestamp) / 1e9;
  const int ret =
      ln_.write(port_, packet_.data(), static_cast<unsigned int>(packet_.size()), source_timestamp ? &stamp : nullptr);
  if (ret < 0)
    state_.error(ln_.error("LN write", ret));
  else
    ++state_.forwarded;
}

}  // namespace msg_mapping::bridge
