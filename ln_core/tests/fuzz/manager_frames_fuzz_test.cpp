// Fuzz target: frames sent to the manager, before and after hello, as raw
// bytes, as mutated encodings of every request of protocol/methods.hpp and
// as well-formed requests with mutated field values. The manager must stay
// up, never report an internal error, and serve a normal client after.
#include <gtest/gtest.h>

#include <cstdio>
#include <memory>

#include "fuzz.hpp"
#include "manager/test_support.hpp"
#include "protocol/methods.hpp"

namespace ln::fuzz {
namespace {

using namespace manager::testing;  // the manager's test support: TempDir, RunningManager, TestClient
using protocol::Message;
namespace method = protocol::method;

std::string framed(const std::string& payload) {
  std::string frame(4, '\0');
  for (int i = 0; i < 4; ++i) frame[static_cast<std::size_t>(i)] = static_cast<char>(payload.size() >> (8 * i));
  return frame + payload;
}

// One valid request of every method (ids and names are plausible, not
// necessarily existing).
std::vector<Message> valid_requests() {
  std::vector<Message> out;
  auto add = [&](std::string_view name, const std::function<void(Message&)>& fill = {}) {
    Message m = Message::request(static_cast<std::uint32_t>(out.size() + 1), name);
    if (fill) fill(m);
    out.push_back(std::move(m));
  };
  add(method::hello, [](Message& m) {
    m.set("program_name", "fuzzed").set("exact", false).set("pid", 1).set("host_name", "h").set("host_id", "id");
    m.set("uid", 0).set("library_version", 1).set("peer_socket", "@s").set("peer_address", "127.0.0.1:9");
  });
  add(method::ping);
  add(method::get_message_definition, [](Message& m) { m.set("name", "mt/point"); });
  add(method::get_message_definition_for_topic, [](Message& m) { m.set("topic", "fuzz.topic"); });
  add(method::put_message_definition,
      [](Message& m) { m.set("name", "fuzz/def").set("text", "double x\nint32_t y[3]\n"); });
  add(method::publish,
      [](Message& m) { m.set("topic", "fuzz.topic").set("message_definition", "mt/point").set("buffers", 2); });
  add(method::publisher_ready, [](Message& m) { m.set("topic_id", 2).set("segment_generation", 1).set("packets", 0); });
  add(method::unpublish, [](Message& m) { m.set("topic_id", 2); });
  add(method::subscribe, [](Message& m) {
    m.set("topic", "fuzz.topic").set("message_definition", "mt/point").set("buffers", 3).set("rate", -1.0);
    m.set("reliable", false).set("receive_address", "127.0.0.1:9");
  });
  add(method::unsubscribe, [](Message& m) { m.set("subscription_id", 3); });
  add(method::register_service, [](Message& m) {
    m.set("name", "fuzz.svc").set("interface", "mt/add").set("signature", "int32_t 4 1|int32_t 4 1").set("group", "");
  });
  add(method::unregister_service, [](Message& m) { m.set("service_id", 4); });
  add(method::lookup_service, [](Message& m) { m.set("name", "fuzz.svc").set("interface", "").set("signature", ""); });
  add(method::get_service_signature, [](Message& m) { m.set("interface", "mt/add"); });
  add(method::get_service_signature_for_service, [](Message& m) { m.set("name", "fuzz.svc"); });
  add(method::find_services_with_interface, [](Message& m) { m.set("interface", "mt/add"); });
  add(method::list_clients);
  add(method::list_topics);
  add(method::list_services);
  add(method::manager_status);
  add(method::goodbye);
  Message stats = Message::notification(method::topic_stats);
  stats.set("topic_id", 2).set("packets", 10);
  out.push_back(stats);
  return out;
}

// The same request with one field replaced by a value of any type.
Message mutate_field(Message m, Mutator& mutator) {
  const auto& fields = m.fields();
  if (fields.empty()) return m;
  auto it = fields.begin();
  std::advance(it, static_cast<long>(mutator.below(fields.size())));
  const std::string key = it->first;
  switch (mutator.below(6)) {
    case 0:
      m.set(key, static_cast<std::int64_t>(mutator.below(5)) - 2);
      break;
    case 1:
      m.set(key, std::int64_t{1} << mutator.below(64));
      break;
    case 2:
      m.set(key, mutator.chance(2) ? -0.0 / 1.0 : 1e308 * 10);
      break;  // -0, inf
    case 3:
      m.set(key, mutator.chance(2));
      break;
    case 4:
      m.set(key, mutator.random_bytes(mutator.chance(8) ? 300 : 12));
      break;
    default:
      m.set(key, protocol::StringList{mutator.random_bytes(8), "", std::string(3, '\0')});
      break;
  }
  return m;
}

TEST(FuzzManagerFrames, TheManagerSurvivesAndServes) {
  TempDir dir;
  write_test_definitions(dir);
  RunningManager running(dir);
  Mutator mutator(seed());
  const std::vector<Message> requests = valid_requests();
  std::vector<std::string> corpus;
  for (const Message& m : requests) corpus.push_back(protocol::encode(m).substr(4));

  TestClient bystander(running.port());
  ASSERT_FALSE(bystander.hello("bystander").is_error());
  Budget budget(20000);
  while (budget.next()) {
    TestClient attacker(running.port());
    const std::uint64_t kind = mutator.below(4);
    if (kind != 0 && !attacker.hello("attacker").is_error()) {
      // Registered: first a few valid requests, so that ids exist.
      for (int i = 0; i < 3; ++i) attacker.send_raw(protocol::encode(requests[1 + mutator.below(requests.size() - 1)]));
    }
    const int frames = 1 + static_cast<int>(mutator.below(4));
    for (int i = 0; i < frames; ++i) {
      const Message& base = requests[mutator.below(requests.size())];
      std::string bytes;
      if (kind == 3)
        bytes = mutator.random_bytes(256);
      else if (mutator.chance(2))
        bytes = protocol::encode(mutate_field(base, mutator));
      else {
        const std::string payload = mutator.mutate(protocol::encode(base).substr(4), corpus);
        bytes = mutator.chance(8) ? mutator.mutate(framed(payload), corpus) : framed(payload);
      }
      if (!attacker.send_raw(bytes)) break;
    }
    if (mutator.chance(4)) attacker.no_notification_within(std::chrono::milliseconds(mutator.below(3)));
    if (budget.done() % 250 == 0) {
      ASSERT_FALSE(bystander.call("ping").is_error()) << "seed " << seed();
    }
  }
  EXPECT_EQ(running.count_log("internal"), 0u) << running.log_text();
  std::printf("[fuzz] manager frames: %d rounds, seed %llu\n", budget.done(), static_cast<unsigned long long>(seed()));

  // A normal client after the storm.
  TestClient normal(running.port());
  ASSERT_FALSE(normal.hello("normal").is_error()) << "seed " << seed();
  EXPECT_FALSE(normal.call("ping").is_error());
  const Message published = normal.call("publish", [](Message& m) {
    m.set("topic", "after.fuzz").set("message_definition", "mt/point").set("buffers", 1);
  });
  EXPECT_FALSE(published.is_error()) << published.error_text();
  const Message topics = normal.call("list_topics");
  EXPECT_FALSE(topics.is_error());
  EXPECT_FALSE(bystander.call("ping").is_error());
}

}  // namespace
}  // namespace ln::fuzz
