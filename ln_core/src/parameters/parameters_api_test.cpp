// Parameters through the public C and C++ APIs (ln/parameters.h,
// ln/parameter_client.h, ln/parameters_c.h) between clients of one
// in-process manager: what a provider answers, reading and overriding,
// callbacks, wait_step, errors, name prefix, sync handling, clients that
// come and go, and ln_client_set_float_parameter().
#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <thread>

#include "client/client_test_support.hpp"
#include "ln/ln.h"
#include "ln/parameters.h"
#include "ln_parameter_messages.h"

namespace ln::clienttest {
namespace {

using ln::parameters::parameter_block;
using ln::parameters::port_description;

/// Calls update() of `block` every millisecond in a thread of its own, as a
/// control loop would, until destroyed.
class UpdateLoop {
 public:
  explicit UpdateLoop(parameter_block& block)
      : thread_([this, &block] {
          while (!stop_) {
            block.update();
            ++steps_;
            std::this_thread::sleep_for(1ms);
          }
        }) {}
  ~UpdateLoop() {
    stop_ = true;
    thread_.join();
  }
  long steps() const { return steps_; }

 private:
  std::atomic<bool> stop_{false};
  std::atomic<long> steps_{0};
  std::thread thread_;
};

class Parameters : public ::testing::Test {
 protected:
  InProcessManager manager;
  ScopedEnv no_prefix{"LN_PARAMETER_PREFIX", std::nullopt};
  ScopedEnv no_sync{"LN_PARAMETER_SYNC_HANDLING", std::nullopt};

  std::unique_ptr<ln::client> client(const std::string& name) {
    return std::make_unique<ln::client>(name, manager.address());
  }
  /// The query_dict answer of `provider` for `pattern`.
  std::string query_dict(ln::client& caller, const std::string& provider, const std::string& pattern) {
    ln::service* svc = caller.get_service("ln.parameters.query_dict." + provider, "ln/parameters/query_dict",
                                          LN_PARAMETERS_QUERY_DICT_SIGNATURE);
    ln_parameters_query_dict_t data{};
    data.req.pattern = const_cast<char*>(pattern.c_str());
    data.req.pattern_len = static_cast<uint32_t>(pattern.size());
    svc->call(&data);
    const std::string text(data.resp.data, data.resp.data_len);
    caller.release_service(svc);
    return text;
  }
};

TEST_F(Parameters, ProviderAnswersQueryDictAsLn29Does) {
  auto provider = client("prov");
  double gain = 1.5, gain_out = 0;
  int32_t count = 7, count_out = 0;
  float vec[3] = {1, 2, 3}, vec_out[3];
  double mat[2][3] = {{1, 2, 3}, {4, 5, 6}}, mat_out[2][3];
  bool flag = true, flag_out = false;
  parameter_block block(provider.get(), "ctrl");
  ASSERT_TRUE(block.register_parameters(port_description<double>("gain", "the gain", &gain, &gain_out),
                                        port_description<int32_t>("count", "a count", &count, &count_out),
                                        port_description<float[3]>("vec", "", &vec, &vec_out),
                                        port_description<double[2][3]>("sub.mat", "matrix", &mat, &mat_out),
                                        port_description<bool>("flag", "it's", &flag, &flag_out)))
      << block.error_message();
  auto caller = client("caller");
  // The text LN 2.9's provider sends for the same block (observed).
  EXPECT_EQ(query_dict(*caller, "prov", "*"),
            "{\n"
            "  'ctrl.gain': dict(input=1.5, output=1.5, override_enabled=False, description='the gain'),\n"
            "  'ctrl.count': dict(input=7, output=7, override_enabled=False, description='a count'),\n"
            "  'ctrl.vec': dict(input=array([1., 2., 3.], dtype=float), output=array([1., 2., 3.], dtype=float), "
            "override_enabled=False, description=''),\n"
            "  'ctrl.sub.mat': dict(input=array([[1., 2., 3.], [4., 5., 6.]], dtype=double), output=array([[1., 2., "
            "3.], [4., 5., 6.]], dtype=double), override_enabled=False, description='matrix'),\n"
            "  'ctrl.flag': dict(input=True, output=True, override_enabled=False, description='it\\'s'),\n"
            "}\n");
  EXPECT_EQ(query_dict(*caller, "prov", "ctrl.gain,ctrl.flag").find("ctrl.count"), std::string::npos);
  EXPECT_EQ(query_dict(*caller, "prov", "x*"), "{\n}\n");
  EXPECT_EQ(query_dict(*caller, "prov", ""), "{\n}\n");
}

TEST_F(Parameters, ReadOverrideAndResetWithTheStepsOfTheProvider) {
  auto provider = client("prov");
  double gain = 1.5, gain_out = 0;
  std::atomic<int> applied{0};
  std::atomic<double> applied_value{0};
  std::thread::id update_thread;
  std::atomic<bool> applied_in_update_thread{false};
  int16_t mat[2][2] = {{1, -2}, {3, -4}}, mat_out[2][2] = {};
  parameter_block block(provider.get(), "ctrl");
  ASSERT_TRUE(block.register_parameters(port_description<double>("gain", "the gain", &gain, &gain_out, nullptr,
                                                                 [&](double& v) {
                                                                   applied_value = v;
                                                                   applied_in_update_thread =
                                                                       std::this_thread::get_id() == update_thread;
                                                                   ++applied;
                                                                 }),
                                        port_description<int16_t[2][2]>("mat", "", &mat, &mat_out)));
  auto caller = client("caller");
  auto params = caller->get_parameters("ctrl");
  EXPECT_EQ(params.get_input<double>("gain"), 1.5);
  EXPECT_EQ(params.get_description("gain"), "the gain");
  EXPECT_EQ(params.get_input<std::vector<std::vector<int>>>("mat"), (std::vector<std::vector<int>>{{1, -2}, {3, -4}}));

  {
    std::thread loop_thread;
    std::atomic<bool> stop{false};
    loop_thread = std::thread([&] {
      update_thread = std::this_thread::get_id();
      while (!stop) {
        block.update();
        std::this_thread::sleep_for(1ms);
      }
    });
    params.set_override("gain", 2.5);  // waits for the step that applied it
    EXPECT_EQ(applied.load(), 1);
    EXPECT_EQ(applied_value.load(), 2.5);
    EXPECT_TRUE(applied_in_update_thread.load());
    EXPECT_EQ(params.get_output<double>("gain"), 2.5);
    EXPECT_EQ(params.get_input<double>("gain"), 1.5);
    EXPECT_TRUE(params.get_internal_value("gain").override_enabled);
    params.set_override("mat", std::array<std::array<int, 2>, 2>{{{9, 8}, {7, 6}}});
    params.reset_override("gain");
    EXPECT_EQ(params.get_output<double>("gain"), 1.5);
    EXPECT_EQ(applied.load(), 1);  // ending an override is no new value
    stop = true;
    loop_thread.join();
  }
  EXPECT_EQ(gain_out, 1.5);
  EXPECT_EQ(mat_out[0][0], 9);
  EXPECT_EQ(mat_out[1][1], 6);

  // Without wait_step the value is in effect for readers at once, and in
  // the program's output at its next update.
  params.set_override("gain", 4.0, false);
  EXPECT_EQ(params.get_output<double>("gain"), 4.0);
  EXPECT_EQ(gain_out, 1.5);
  block.update();
  EXPECT_EQ(gain_out, 4.0);
  // The input is read at every update.
  gain = 0.25;
  block.update();
  EXPECT_EQ(params.get_input<double>("gain"), 0.25);
  EXPECT_EQ(gain_out, 4.0);
}

TEST_F(Parameters, BeforeUpdateRefusesValuesWithAnErrorForTheCaller) {
  auto provider = client("prov");
  int32_t limit = 5, limit_out = 0;
  parameter_block block(provider.get(), "cb");
  ASSERT_TRUE(block.register_parameters(
      port_description<int32_t>("limit", "", &limit, &limit_out, [](int32_t& v) { return v < 10; })));
  UpdateLoop loop(block);
  auto caller = client("caller");
  auto params = caller->get_parameters("cb");
  params.set_override("limit", 7);
  EXPECT_EQ(params.get_output<int>("limit"), 7);
  try {
    params.set_override("limit", 12);
    FAIL() << "the check should have refused 12";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("refused"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("cb.limit"), std::string::npos) << e.what();
  }
  EXPECT_EQ(params.get_output<int>("limit"), 7);  // the earlier override stays
}

TEST_F(Parameters, BadInputGetsClearErrors) {
  auto provider = client("prov");
  double d[4] = {1, 2, 3, 4}, d_out[4];
  int8_t s8 = -5, s8_out;
  parameter_block block(provider.get(), "all");
  ASSERT_TRUE(block.register_parameters(port_description<double[4]>("d", "", &d, &d_out),
                                        port_description<int8_t>("s8", "", &s8, &s8_out)));
  UpdateLoop loop(block);
  auto caller = client("caller");
  auto params = caller->get_parameters("all");
  auto error_of = [](const std::function<void()>& f) -> std::string {
    try {
      f();
    } catch (const std::runtime_error& e) {
      return e.what();
    }
    return "<no error>";
  };
  EXPECT_NE(error_of([&] { params.get_input<double>("nothere"); }).find("no client provides parameter 'all.nothere'"),
            std::string::npos);
  EXPECT_NE(error_of([&] { params.get_input<double>("d"); }).find("has shape [4]"), std::string::npos);
  EXPECT_NE(error_of([&] { params.get_input<std::array<double, 3>>("d"); }).find("shape [3]"), std::string::npos);
  EXPECT_NE(error_of([&] {
              params.set_override("d", std::vector<double>{1, 2, 3});
            }).find("shape [3]"),
            std::string::npos);
  EXPECT_NE(error_of([&] { params.set_override("s8", 300); }).find("300 does not fit int8 (-128..127)"),
            std::string::npos);
  EXPECT_NE(error_of([&] { params.get_input<uint8_t>("s8"); }).find("-5 does not fit uint8"), std::string::npos);
  EXPECT_NE(error_of([&] { caller->get_parameters("all", true).get_input<double>("s8"); }).find("signed integer"),
            std::string::npos);
  EXPECT_NE(error_of([&] { ln::parameters::parameter_proxy().get_input<double>("x"); }).find("not bound"),
            std::string::npos);
  EXPECT_NE(error_of([&] {
              params.set_override("m", std::vector<std::vector<double>>{{1, 2}, {3}});
            }).find("not rectangular"),
            std::string::npos);

  // Text overrides: the provider's answer reaches the caller.
  ln_client c = caller->clnt;
  EXPECT_EQ(ln_parameter_override_text(c, "all.d", "array([1, 2, 3])", 0), -LNE_REQUEST_FAILED);
  EXPECT_NE(std::string(ln_get_error_message(c)).find("takes 4 values, the list has 3"), std::string::npos)
      << ln_get_error_message(c);
  EXPECT_EQ(ln_parameter_override_text(c, "all.s8", "abc", 0), -LNE_REQUEST_FAILED);
  EXPECT_NE(std::string(ln_get_error_message(c)).find("'abc' is not a number"), std::string::npos);
  EXPECT_EQ(ln_parameter_override_text(c, "all.nothere", "1", 0), -LNE_UNKNOWN_PARAMETER);
  EXPECT_EQ(ln_parameter_override_text(c, "all.d", "[5, 6, 7, 8]", LN_PARAMETER_WAIT_STEP), 0);
  EXPECT_EQ(params.get_output<std::vector<double>>("d"), (std::vector<double>{5, 6, 7, 8}));
  EXPECT_EQ(ln_parameter_override_text(c, nullptr, "1", 0), -LNE_INVALID_PARAMETER);
  ln_parameter_value value{};
  EXPECT_EQ(ln_parameter_get(nullptr, "all.d", 0, &value), -LNE_CLIENT_NOT_INITIALIZED);
  EXPECT_EQ(ln_parameter_get(c, "all.d", 0, nullptr), -LNE_INVALID_PARAMETER);
}

TEST_F(Parameters, RegistrationRefusesWhatCannotWork) {
  auto provider = client("prov");
  double a = 1, a_out;
  parameter_block first(provider.get(), "g");
  ASSERT_TRUE(first.register_parameters(port_description<double>("a", "", &a, &a_out)));
  EXPECT_FALSE(first.register_parameters(port_description<double>("b", "", &a, &a_out)));
  EXPECT_NE(first.error_message().find("registered already"), std::string::npos) << first.error_message();

  parameter_block second(provider.get(), "g");
  EXPECT_FALSE(second.register_parameters(port_description<double>("a", "", &a, &a_out)));
  EXPECT_NE(second.error_message().find("'g.a' is provided by block 'g'"), std::string::npos) << second.error_message();
  EXPECT_THROW(second.update(), ln::exception);  // not registered

  parameter_block third(provider.get(), "h");
  EXPECT_FALSE(third.register_parameters(port_description<double>("", "", &a, &a_out)));
  EXPECT_FALSE(third.register_parameters(port_description<double>("x", "", nullptr, &a_out)));
  EXPECT_NE(third.error_message().find("input pointer is NULL"), std::string::npos);
  EXPECT_FALSE(third.register_parameters(port_description<double>("x", "", &a, &a_out),
                                         port_description<double>("x", "", &a, &a_out)));
  EXPECT_NE(third.error_message().find("registered twice"), std::string::npos);
  uint32_t bad_dims[3] = {2, 2, 2};
  std::vector<ln::parameters::port_description_void2> cube{
      {"cube", "", 8, ln::parameters::LN_DOUBLE, 3, bad_dims, &a, nullptr, nullptr, nullptr, true}};
  EXPECT_FALSE(third.register_parameters(cube));
  EXPECT_NE(third.error_message().find("1 or 2 dimensions"), std::string::npos);
  std::vector<ln::parameters::port_description_void2> unknown_type{
      {"t", "", 1, 99, 1, nullptr, &a, nullptr, nullptr, nullptr, false}};
  EXPECT_FALSE(third.register_parameters(unknown_type));
  EXPECT_NE(third.error_message().find("unknown type id 99"), std::string::npos);
  // After all that, the block still registers what is valid.
  EXPECT_TRUE(third.register_parameters(port_description<double>("x", "", &a, &a_out))) << third.error_message();
}

TEST_F(Parameters, WaitingForAStepEndsWhenTheBlockGoes) {
  auto provider = client("prov");
  double a = 1, a_out;
  auto block = std::make_unique<parameter_block>(provider.get(), "g");
  ASSERT_TRUE(block->register_parameters(port_description<double>("a", "", &a, &a_out)));
  auto caller = client("caller");
  std::string error;
  std::thread overriding([&] {
    try {
      caller->get_parameters("g").set_override("a", 2.0);  // no update() comes
    } catch (const std::runtime_error& e) {
      error = e.what();
    }
  });
  // Once the override is in effect the caller waits for the step.
  ASSERT_TRUE(wait_until([&] { return caller->get_parameters("g").get_output<double>("a") == 2.0; }));
  const auto before = Clock::now();
  block.reset();
  overriding.join();
  EXPECT_LT(Clock::now() - before, 2s);
  EXPECT_NE(error.find("destroyed before its next update"), std::string::npos) << error;
}

TEST_F(Parameters, ProvidersAreFoundAgainAfterTheyComeBack) {
  auto caller = client("caller");
  double a = 1, a_out;
  {
    auto provider = client("prov");
    parameter_block block(provider.get(), "g");
    ASSERT_TRUE(block.register_parameters(port_description<double>("a", "", &a, &a_out)));
    EXPECT_EQ(caller->get_parameters("g").get_input<double>("a"), 1);
  }
  EXPECT_THROW(caller->get_parameters("g").get_input<double>("a"), std::runtime_error);
  a = 3;
  auto provider = client("other");
  parameter_block block(provider.get(), "g");
  ASSERT_TRUE(block.register_parameters(port_description<double>("a", "", &a, &a_out)));
  EXPECT_EQ(caller->get_parameters("g").get_input<double>("a"), 3);

  // A name provided twice is an error naming both providers.
  auto twin = client("twin");
  parameter_block twin_block(twin.get(), "g");
  ASSERT_TRUE(twin_block.register_parameters(port_description<double>("a", "", &a, &a_out)));
  ln_parameter_value value{};
  EXPECT_EQ(ln_parameter_get(caller->clnt, "g.a", LN_PARAMETER_REDISCOVER, &value), -LNE_INVALID_PARAMETER);
  const std::string message = ln_get_error_message(caller->clnt);
  EXPECT_NE(message.find("client 'other'"), std::string::npos) << message;
  EXPECT_NE(message.find("client 'twin'"), std::string::npos) << message;
}

TEST_F(Parameters, PrefixAndSyncHandling) {
  ScopedEnv prefix("LN_PARAMETER_PREFIX", std::string("robot1."));
  ScopedEnv sync("LN_PARAMETER_SYNC_HANDLING", std::string("1"));
  auto provider = client("prov");
  double x = 1, x_out = 0;
  std::thread::id checked_in;
  parameter_block block(provider.get(), "s");
  ASSERT_TRUE(block.register_parameters(port_description<double>("x", "", &x, &x_out, [&](double&) {
    checked_in = std::this_thread::get_id();
    return true;
  })));
  EXPECT_EQ(block.name(), "robot1.s");
  auto caller = client("caller");
  std::atomic<bool> stop{false};
  std::thread::id update_thread;
  std::thread loop([&] {
    update_thread = std::this_thread::get_id();
    while (!stop) {
      block.update();
      std::this_thread::sleep_for(1ms);
    }
  });
  auto params = caller->get_parameters("robot1.s");
  params.set_override("x", 5.0);
  EXPECT_EQ(params.get_output<double>("x"), 5.0);
  params.reset_override("x");
  EXPECT_EQ(params.get_output<double>("x"), 1.0);
  stop = true;
  loop.join();
  EXPECT_EQ(checked_in, update_thread);  // handled inside update()
  EXPECT_EQ(x_out, 1.0);
}

TEST_F(Parameters, UpdateWithOtherPointersAndOnlyInputs) {
  auto provider = client("prov");
  double x = 1, x_out = 0, other_in = 100, other_out = -1;
  parameter_block block(provider.get(), "s");
  ASSERT_TRUE(block.register_parameters(port_description<double>("x", "", &x, &x_out)));
  const void* inputs[1] = {&other_in};
  void* outputs[1] = {&other_out};
  block.update(inputs, outputs, false);
  EXPECT_EQ(other_out, 100);
  EXPECT_EQ(x_out, 0);
  other_out = -1;
  other_in = 200;
  block.update(inputs, outputs, true);  // only inputs: no output written
  EXPECT_EQ(other_out, -1);
  auto caller = client("caller");
  EXPECT_EQ(caller->get_parameters("s").get_input<double>("x"), 200);
}

TEST_F(Parameters, ColumnMajorProgramsAndMatricesOfOneRow) {
  auto provider = client("prov");
  // A column-major 2x3 matrix (as Eigen keeps it): 1 2 3 / 4 5 6.
  double column_major[6] = {1, 4, 2, 5, 3, 6}, out[6] = {};
  uint32_t dims[2] = {2, 3};
  double row[1][3] = {{7, 8, 9}}, row_out[1][3];
  parameter_block block(provider.get(), "m");
  std::vector<ln::parameters::port_description_void2> described{
      {"cm", "", 6, ln::parameters::LN_DOUBLE, 2, dims, column_major, out, nullptr, nullptr, false}};
  ASSERT_TRUE(block.register_parameters(described));
  parameter_block rows(provider.get(), "r");
  ASSERT_TRUE(rows.register_parameters(port_description<double[1][3]>("one_row", "", &row, &row_out)));
  auto caller = client("caller");
  auto params = caller->get_parameters("m");
  EXPECT_EQ(params.get_input<std::vector<std::vector<double>>>("cm"),
            (std::vector<std::vector<double>>{{1, 2, 3}, {4, 5, 6}}));
  EXPECT_NE(query_dict(*caller, "prov", "m.cm").find("array([[1., 2., 3.], [4., 5., 6.]], dtype=double)"),
            std::string::npos);
  params.set_override("cm", std::vector<std::vector<double>>{{10, 20, 30}, {40, 50, 60}}, false);
  block.update();
  EXPECT_EQ(std::vector<double>(out, out + 6), (std::vector<double>{10, 40, 20, 50, 30, 60}));
  // 1 x n: a matrix in C++ (as LN 2.9 reports it), a list in the text.
  auto r = caller->get_parameters("r");
  EXPECT_EQ(r.get_internal_value("one_row").shape, (std::vector<std::size_t>{1, 3}));
  r.set_override("one_row", std::vector<std::vector<double>>{{1, 2, 3}}, false);
  EXPECT_NE(query_dict(*caller, "prov", "r.one_row").find("output=array([1., 2., 3.], dtype=double)"),
            std::string::npos);
}

TEST_F(Parameters, TheClientGoingFirstLeavesBlocksHarmless) {
  auto provider = client("prov");
  double a = 1, a_out;
  parameter_block block(provider.get(), "g");
  ASSERT_TRUE(block.register_parameters(port_description<double>("a", "", &a, &a_out)));
  ln_client raw = provider->clnt;
  ASSERT_EQ(ln_deinit(&raw), 0);  // the C client under the C++ wrapper
  provider->clnt = nullptr;
  EXPECT_THROW(block.update(), ln::exception);
}

TEST_F(Parameters, TopicsOnRequestAndAlways) {
  auto provider = client("prov");
  double a = 1, a_out;
  int16_t v[2] = {3, 4}, v_out[2];
  parameter_block block(provider.get(), "g");
  ASSERT_TRUE(block.register_parameters(port_description<double>("a", "", &a, &a_out),
                                        port_description<int16_t[2]>("v", "", &v, &v_out)));
  auto caller = client("caller");
  ln::service* svc = caller->get_service("ln.parameters.request_topic.prov", "ln/parameters/request_parameter_topic",
                                         LN_PARAMETERS_REQUEST_PARAMETER_TOPIC_SIGNATURE);
  auto request = [&](std::string names) {
    ln_parameters_request_parameter_topic_t data{};
    data.req.parameters = &names[0];
    data.req.parameters_len = static_cast<uint32_t>(names.size());
    svc->call(&data);
    return std::make_pair(std::string(data.resp.parameter_topics, data.resp.parameter_topics_len),
                          std::string(data.resp.error, data.resp.error_len));
  };
  const auto [topics, error] = request("g.a, g.v");
  EXPECT_EQ(error, "");
  const std::size_t md = topics.find("'gen/ln/parameters/s_");
  ASSERT_NE(md, std::string::npos) << topics;
  const std::string md_name = topics.substr(md + 1, topics.find('\'', md + 1) - md - 1);
  EXPECT_EQ(topics, "{\n  'g.a': ('prov.g', '" + md_name + "'),\n  'g.v': ('prov.g', '" + md_name + "'),\n}\n");
  EXPECT_NE(request("g.nothere").second.find("no parameter 'g.nothere'"), std::string::npos);
  EXPECT_NE(request("").second.find("no parameter names"), std::string::npos);
  EXPECT_NE(request("g.*").second.find("matches 2"), std::string::npos);
  caller->release_service(svc);

  // Requested: published at every update for a while.
  ln::inport* port = caller->subscribe("prov.g", md_name);
  std::vector<uint8_t> packet(2 * 8 + 1 + 2 * 4 + 1);
  ASSERT_EQ(port->message_size, packet.size());
  ASSERT_TRUE(wait_until([&] {
    block.update();
    return port->read(packet.data(), 0.0);
  }));
  double input;
  std::memcpy(&input, packet.data(), 8);
  EXPECT_EQ(input, 1.0);
  EXPECT_EQ(packet[17] | packet[18] << 8, 3);  // g.v input[0]

  // Always: from registration on, under the topic name given.
  parameter_block always(provider.get(), "h", true, "my.topic");
  ASSERT_TRUE(always.register_parameters(port_description<double>("b", "", &a, &a_out)));
  ln::inport* always_port = caller->subscribe("my.topic", "");
  ASSERT_TRUE(wait_until([&] {
    always.update();
    return always_port->read(packet.data(), 0.0);
  }));
}

TEST_F(Parameters, SetFloatParameterKnowsLn29sSettings) {
  auto c = client("settings");
  EXPECT_EQ(ln_client_set_float_parameter(nullptr, "__LN_CPP_WRAPPER_VERSION", 32), 0);
  EXPECT_EQ(ln_client_set_float_parameter(c->clnt, "debug", 0), 0);
  EXPECT_EQ(ln_client_set_float_parameter(c->clnt, "reconnect_interval", 0.2f), 0);
  EXPECT_EQ(ln_client_set_float_parameter(c->clnt, "win32_async_ping_timeout", 1), 0);
  EXPECT_EQ(ln_client_set_float_parameter(c->clnt, "win32_async_ping_interval", 1), 0);
  EXPECT_EQ(ln_client_set_float_parameter(c->clnt, "win32_wait_for_service_request_timeout", 1), 0);
  EXPECT_EQ(ln_client_set_float_parameter(c->clnt, "reconnect_interval", -1), -LNE_INVALID_PARAMETER);
  EXPECT_EQ(ln_client_set_float_parameter(c->clnt, "reconnect_interval", NAN), -LNE_INVALID_PARAMETER);
  EXPECT_EQ(ln_client_set_float_parameter(c->clnt, "foo", 1), -LNE_UNKNOWN_PARAMETER);
  EXPECT_NE(std::string(ln_get_error_message(c->clnt)).find("unknown client setting 'foo'"), std::string::npos);
  EXPECT_EQ(ln_client_set_float_parameter(c->clnt, nullptr, 1), -LNE_INVALID_PARAMETER);
  EXPECT_EQ(ln_client_set_float_parameter(nullptr, "debug", 1), -LNE_CLIENT_NOT_INITIALIZED);
  c->set_float_parameter("debug", 0);
  EXPECT_THROW(c->set_float_parameter("nonsense", 1), ln::exception);
}

}  // namespace
}  // namespace ln::clienttest
