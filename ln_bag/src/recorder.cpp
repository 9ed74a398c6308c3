#include "ln_bag/recorder.hpp"

#include <ln/ln.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <ctime>
#include <deque>
#include <functional>
#include <future>
#include <mutex>
#include <thread>

namespace ln_bag {
namespace {

std::uint64_t wall_ns() {
  timespec ts{};
  ::clock_gettime(CLOCK_REALTIME, &ts);
  return static_cast<std::uint64_t>(ts.tv_sec) * 1000000000u + static_cast<std::uint64_t>(ts.tv_nsec);
}

double monotonic_seconds() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

/// An LN timestamp (seconds) as MCAP nanoseconds, the nearest nanosecond (the
/// whole seconds apart: seconds * 1e9 as one double would be off by up to
/// 128 ns); 0 where it has none.
std::uint64_t timestamp_ns(double seconds) {
  if (!(seconds > 0) || !std::isfinite(seconds) || seconds >= 1.8e10) return 0;
  const double whole = std::floor(seconds);
  return static_cast<std::uint64_t>(whole) * 1000000000u +
         static_cast<std::uint64_t>(std::llround((seconds - whole) * 1e9));
}

std::string ln_failure(ln_client client, int code) {
  const char* detail = client ? ln_get_error_message(client) : nullptr;
  std::string text = ln_format_error(code);
  if (detail && *detail) text += ": " + std::string(detail);
  return text;
}

// Work for the recording thread (it owns the LN client once it runs).
struct Command {
  std::function<void()> work;
  std::promise<void> done;

  void run() {
    try {
      work();
      done.set_value();
    } catch (...) {
      done.set_exception(std::current_exception());
    }
  }
  void refuse(const std::string& why) { done.set_exception(std::make_exception_ptr(BagError(why))); }
};

struct Topic {
  std::string name;
  std::unique_ptr<TopicMapping> mapping;
  ln_inport port = nullptr;
  std::uint16_t channel = 0;
  std::size_t fixed_cdr_size = 0;
  unsigned buffers = 0;
  bool active = true;
  std::atomic<std::uint64_t> messages{0}, bytes{0}, lost{0};
  std::string error;  // guarded by Impl::mutex
};

}  // namespace

struct Recorder::Impl {
  McapWriter& writer;
  RecorderOptions options;
  ln_client client = nullptr;
  ln_multi_waiter waiter = nullptr;

  mutable std::mutex mutex;
  std::condition_variable changed;
  std::deque<Command> commands;
  std::vector<std::unique_ptr<Topic>> topics;    // appended by the recording thread (or before it runs)
  std::map<std::string, std::uint16_t> schemas;  // ROS type + schema text -> schema id
  std::atomic<bool> stop_requested{false};
  bool running = false, finished = false;
  std::string error;
  std::atomic<std::uint64_t> total{0};
  std::thread thread;

  Impl(McapWriter& w, RecorderOptions o) : writer(w), options(std::move(o)) {}

  std::uint16_t subscribe(const std::string& name, const std::string& ros_topic, const TopicMapping& mapping,
                          const std::map<std::string, std::string>& metadata, unsigned buffers) {
    for (const auto& t : topics)
      if (t->name == name) throw BagError("topic '" + name + "' is already being recorded");
    auto topic = std::make_unique<Topic>();
    topic->name = name;
    topic->mapping = std::make_unique<TopicMapping>(mapping.ln_name(), mapping.texts());
    topic->fixed_cdr_size = topic->mapping->codec().fixed_cdr_size();
    topic->buffers = buffers ? buffers : 1;
    const std::string pinned = mapping.ln_name() + "|" + mapping.ln_hash();
    int r = ln_subscribe_with_buffers(client, name.c_str(), pinned.c_str(), &topic->port, RATE_AS_PUBLISHED, 1,
                                      topic->buffers);
    if (r < 0) throw BagError("cannot subscribe to topic '" + name + "': " + ln_failure(client, r));
    const int size = ln_get_message_size(topic->port);
    if (size < 0 || static_cast<std::size_t>(size) != mapping.packet_size()) {
      ln_unsubscribe(&topic->port);
      throw BagError("topic '" + name + "': packets of " + std::to_string(size) + " bytes, but definition '" +
                     mapping.ln_name() + "' has " + std::to_string(mapping.packet_size()));
    }
    if ((r = ln_multi_waiter_add_port(waiter, topic->port)) < 0) {
      ln_unsubscribe(&topic->port);
      throw BagError("topic '" + name + "': " + ln_failure(client, r));
    }
    topic->channel = channel_for(ros_topic, mapping, metadata);
    const std::uint16_t channel = topic->channel;
    std::lock_guard<std::mutex> lock(mutex);
    topics.push_back(std::move(topic));
    return channel;
  }

  // A channel of `mapping`'s ROS type (its schema added once).
  std::uint16_t channel_for(const std::string& ros_topic, const TopicMapping& mapping,
                            const std::map<std::string, std::string>& metadata) {
    const std::string schema_key = mapping.ros_type() + '\n' + mapping.schema();
    auto schema = schemas.find(schema_key);
    if (schema == schemas.end())
      schema =
          schemas.emplace(schema_key, writer.add_schema(mapping.ros_type(), ros2msg_encoding, mapping.schema())).first;
    return writer.add_channel(schema->second, ros_topic, "cdr", metadata);
  }

  // Runs `work` in the recording thread once it runs (at once before), waiting for it or not.
  void in_recording_thread(std::function<void()> work, bool wait) {
    Command command{std::move(work), {}};
    std::future<void> done = command.done.get_future();
    {
      std::unique_lock<std::mutex> lock(mutex);
      if (finished) throw BagError("the recording has ended" + (error.empty() ? "" : ": " + error));
      if (running) {
        commands.push_back(std::move(command));
      } else {
        lock.unlock();
        command.run();
      }
    }
    if (wait) done.get();  // rethrows the command's BagError
  }

  // Records every packet the topic has; returns how many.
  std::size_t drain(Topic& t) {
    std::size_t n = 0;
    for (;;) {
      if (options.max_messages && total.load(std::memory_order_relaxed) >= options.max_messages) return n;
      const void* packet = nullptr;
      unsigned int size = 0;
      ln_sample_info info{};
      const int r = ln_read_borrow(t.port, &packet, &size, &info, 0);
      if (r == 0) return n;
      if (r < 0) {
        drop(t, "reading failed: " + ln_failure(client, r));
        return n;
      }
      const std::uint64_t log_time = wall_ns();
      try {
        const msg_mapping::Codec& codec = t.mapping->codec();
        const msg_mapping::Bytes in{static_cast<const std::uint8_t*>(packet), size};
        const std::size_t cdr_size = t.fixed_cdr_size ? t.fixed_cdr_size : codec.cdr_size(in);
        std::uint8_t* out = writer.reserve_message(cdr_size);
        const std::size_t written = codec.ln_to_cdr(in, {out, cdr_size});
        writer.commit_message(t.channel, static_cast<std::uint32_t>(info.sequence), log_time,
                              timestamp_ns(info.timestamp), written);
        t.bytes.fetch_add(written, std::memory_order_relaxed);
      } catch (const msg_mapping::CodecError& e) {
        ln_read_release(t.port);
        drop(t, std::string("a packet could not be converted: ") + e.what());
        return n;
      } catch (...) {
        ln_read_release(t.port);
        throw;
      }
      ln_read_release(t.port);
      t.messages.fetch_add(1, std::memory_order_relaxed);
      t.lost.fetch_add(info.lost, std::memory_order_relaxed);
      total.fetch_add(1, std::memory_order_relaxed);
      ++n;
    }
  }

  void drop(Topic& t, const std::string& why) {
    t.active = false;
    ln_multi_waiter_remove_port(waiter, t.port);
    std::lock_guard<std::mutex> lock(mutex);
    t.error = why;
  }

  void run_commands() {
    std::deque<Command> pending;
    {
      std::lock_guard<std::mutex> lock(mutex);
      pending.swap(commands);
    }
    for (auto& command : pending) command.run();
  }

  void run() {
    const double start = monotonic_seconds();
    const auto batch = std::chrono::duration<double>(options.batch_seconds);
    std::string failure;
    try {
      while (!stop_requested.load()) {
        run_commands();
        std::size_t n = 0;
        for (std::size_t i = 0; i < topics.size(); ++i)
          if (topics[i]->active) n += drain(*topics[i]);
        if (options.max_messages && total.load() >= options.max_messages) break;
        if (options.max_seconds > 0 && monotonic_seconds() - start >= options.max_seconds) break;
        const std::uint64_t chunk_start = writer.chunk_start_time();
        if (chunk_start && wall_ns() - chunk_start > options.chunk_seconds * 1e9) writer.flush_chunk();
        if (n > 0) {
          std::this_thread::sleep_for(batch);
        } else {
          double wait = 0.05;
          if (options.max_seconds > 0)
            wait = std::min(wait, std::max(0.0, start + options.max_seconds - monotonic_seconds()));
          ln_multi_waiter_wait(waiter, wait);  // also returns at once while it has no port
          if (topics.empty()) std::this_thread::sleep_for(std::chrono::duration<double>(wait));
        }
      }
      run_commands();  // what was posted before the end still goes in
      writer.flush_chunk();
    } catch (const std::exception& e) {
      failure = e.what();
    }
    std::lock_guard<std::mutex> lock(mutex);
    if (!failure.empty()) error = failure;
    for (auto& command : commands) command.refuse("the recording has ended");
    commands.clear();
    finished = true;
    changed.notify_all();
  }
};

Recorder::Recorder(McapWriter& writer, RecorderOptions options)
    : impl_(std::make_unique<Impl>(writer, std::move(options))) {
  Impl& m = *impl_;
  int r = ln_init_to_manager(&m.client, m.options.client_name.c_str(), m.options.manager.c_str());
  if (r < 0) {
    const std::string why = ln_failure(m.client, r);
    if (m.client) ln_deinit(&m.client);
    throw BagError("cannot connect to the ln_manager at " + m.options.manager + ": " + why);
  }
  if ((r = ln_multi_waiter_init(m.client, &m.waiter)) < 0) {
    const std::string why = ln_failure(m.client, r);
    ln_deinit(&m.client);
    throw BagError("cannot create a multi-waiter: " + why);
  }
}

Recorder::~Recorder() {
  stop();
  Impl& m = *impl_;
  for (auto& t : m.topics)
    if (t->port) ln_unsubscribe(&t->port);
  if (m.waiter) ln_multi_waiter_deinit(&m.waiter);
  if (m.client) ln_deinit(&m.client);
}

std::uint16_t Recorder::add_topic(const std::string& topic, const std::string& ros_topic, const TopicMapping& mapping,
                                  const std::map<std::string, std::string>& metadata, unsigned buffers) {
  Impl& m = *impl_;
  std::uint16_t channel = 0;
  m.in_recording_thread([&] { channel = m.subscribe(topic, ros_topic, mapping, metadata, buffers); }, true);
  return channel;
}

std::uint16_t Recorder::add_channel(const std::string& ros_topic, const TopicMapping& mapping,
                                    const std::map<std::string, std::string>& metadata) {
  Impl& m = *impl_;
  std::uint16_t channel = 0;
  m.in_recording_thread([&] { channel = m.channel_for(ros_topic, mapping, metadata); }, true);
  return channel;
}

void Recorder::post_message(std::uint16_t channel_id, std::uint32_t sequence, std::uint64_t log_time,
                            std::uint64_t publish_time, std::string data) {
  Impl& m = *impl_;
  m.in_recording_thread(
      [&m, channel_id, sequence, log_time, publish_time, data = std::move(data)] {
        m.writer.add_message(channel_id, sequence, log_time, publish_time, data.data(), data.size());
        m.total.fetch_add(1, std::memory_order_relaxed);
      },
      false);
}

void Recorder::start() {
  Impl& m = *impl_;
  std::lock_guard<std::mutex> lock(m.mutex);
  if (m.running || m.finished) return;
  m.running = true;
  m.thread = std::thread([&m] { m.run(); });
}

bool Recorder::wait(double timeout) {
  Impl& m = *impl_;
  std::unique_lock<std::mutex> lock(m.mutex);
  if (!m.running) return m.finished;
  if (timeout < 0) {
    m.changed.wait(lock, [&] { return m.finished; });
    return true;
  }
  return m.changed.wait_for(lock, std::chrono::duration<double>(timeout), [&] { return m.finished; });
}

void Recorder::stop() {
  Impl& m = *impl_;
  m.stop_requested = true;
  if (m.thread.joinable()) m.thread.join();
  std::lock_guard<std::mutex> lock(m.mutex);
  m.finished = true;
}

std::string Recorder::error() const {
  std::lock_guard<std::mutex> lock(impl_->mutex);
  return impl_->error;
}

std::vector<TopicStats> Recorder::stats() const {
  std::lock_guard<std::mutex> lock(impl_->mutex);
  std::vector<TopicStats> out;
  for (const auto& t : impl_->topics) {
    TopicStats s;
    s.topic = t->name;
    s.channel_id = t->channel;
    s.messages = t->messages.load(std::memory_order_relaxed);
    s.bytes = t->bytes.load(std::memory_order_relaxed);
    s.lost = t->lost.load(std::memory_order_relaxed);
    s.buffers = t->buffers;
    s.error = t->error;
    out.push_back(std::move(s));
  }
  return out;
}

std::uint64_t Recorder::messages() const { return impl_->total.load(std::memory_order_relaxed); }

}  // namespace ln_bag
