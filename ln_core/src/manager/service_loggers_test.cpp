// Service loggers at the manager (register_as_service_logger): which
// providers and callers learn of which loggers, through responses and
// notifications, against an in-process manager.
#include <gtest/gtest.h>

#include "manager/request_error.hpp"
#include "manager/test_support.hpp"

namespace ln::manager::testing {
namespace {

class ServiceLoggerTest : public ::testing::Test {
 protected:
  std::unique_ptr<TestClient> client(const std::string& name) {
    auto c = std::make_unique<TestClient>(manager.port());
    EXPECT_FALSE(c->hello(name).is_error());
    return c;
  }
  static Message provide(TestClient& c, const std::string& name, const std::string& interface = "mt/echo") {
    return c.call("register_service", [&](Message& m) {
      m.set("name", name).set("interface", interface).set("signature", "s").set("group", "");
    });
  }
  static Message log_as(TestClient& c, const std::string& logger, const std::string& patterns) {
    return c.call("register_as_service_logger",
                  [&](Message& m) { m.set("logger_service", logger).set("patterns", patterns); });
  }
  static Message lookup(TestClient& c, const std::string& name) {
    return c.call("lookup_service", [&](Message& m) { m.set("name", name).set("interface", "").set("signature", ""); });
  }
  // "service logger" of every add_service_logger until quiet; "- logger" for del.
  static std::vector<std::string> logger_news(TestClient& c) {
    std::vector<std::string> news;
    while (auto m = c.next_notification(300ms)) {
      if (m->method() == "add_service_logger")
        news.push_back(m->get_string("service") + " " + m->get_string("logger_service"));
      else if (m->method() == "del_service_logger")
        news.push_back("- " + m->get_string("logger_service"));
    }
    return news;
  }

  TempDir dir;
  const bool definitions_written = (write_test_definitions(dir), true);
  RunningManager manager{dir};
};

TEST_F(ServiceLoggerTest, OnlyOwnLogServicesCanLog) {
  auto logger = client("logger");
  auto other = client("other");
  ASSERT_FALSE(provide(*other, "their.log", "ln/log_service").is_error());
  const Message foreign = log_as(*logger, "their.log", "*");
  EXPECT_EQ(foreign.error_code(), LNE_SVC_NOT_REGISTERED);
  EXPECT_NE(foreign.error_text().find("not a service of yours"), std::string::npos) << foreign.error_text();
  ASSERT_FALSE(provide(*logger, "not.a.logger", "mt/echo").is_error());
  const Message wrong = log_as(*logger, "not.a.logger", "*");
  EXPECT_EQ(wrong.error_code(), LNE_INVALID_PARAMETER);
  EXPECT_NE(wrong.error_text().find("ln/log_service"), std::string::npos) << wrong.error_text();
}

TEST_F(ServiceLoggerTest, ProvidersAndCallersLearnOfMatchingLoggers) {
  auto provider = client("provider");
  auto caller = client("caller");
  ASSERT_FALSE(provide(*provider, "a.one").is_error());
  ASSERT_FALSE(provide(*provider, "a.secret").is_error());
  ASSERT_FALSE(provide(*provider, "b.two").is_error());
  ASSERT_FALSE(lookup(*caller, "a.one").is_error());
  logger_news(*provider);
  logger_news(*caller);

  auto logger = client("logger");
  ASSERT_FALSE(provide(*logger, "the.log", "ln/log_service").is_error());
  ASSERT_FALSE(provide(*logger, "a.own").is_error());
  ASSERT_FALSE(log_as(*logger, "the.log", "a.*,!*.secret,the.*").is_error());
  EXPECT_EQ(logger_news(*provider), (std::vector<std::string>{"a.one the.log"}));
  EXPECT_EQ(logger_news(*caller), (std::vector<std::string>{"a.one the.log"}));
  EXPECT_EQ(logger_news(*logger), (std::vector<std::string>{})) << "not its own services, not the logger itself";

  // Later registrations and lookups carry the loggers in their answers.
  EXPECT_EQ(provide(*provider, "a.three").get_list("log_services"), (protocol::StringList{"the.log"}));
  EXPECT_EQ(provide(*provider, "c.four").get_list("log_services"), (protocol::StringList{}));
  EXPECT_EQ(lookup(*caller, "a.three").get_list("log_services"), (protocol::StringList{"the.log"}));
  EXPECT_EQ(lookup(*logger, "a.three").get_list("log_services"), (protocol::StringList{})) << "its own calls";

  // The logger service goes: everybody hears of it.
  logger->close();
  EXPECT_EQ(logger_news(*provider), (std::vector<std::string>{"- the.log"}));
  EXPECT_EQ(logger_news(*caller), (std::vector<std::string>{"- the.log"}));
  EXPECT_EQ(lookup(*caller, "a.three").get_list("log_services"), (protocol::StringList{}));
}

}  // namespace
}  // namespace ln::manager::testing
