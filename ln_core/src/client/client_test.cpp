// Clients and message definitions through the public API of libln.so,
// against an in-process manager.
#include <gtest/gtest.h>
#include <ln/ln.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "client/client_test_support.hpp"

namespace {

using namespace ln::clienttest;

std::string name_of(ln_client client) {
  char* name = nullptr;
  EXPECT_EQ(ln_client_get_name(client, &name), 0);
  return name != nullptr ? name : "";
}

// A port nobody listens on (bound, then closed).
std::uint16_t unused_port() {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  ::bind(fd, reinterpret_cast<sockaddr*>(&address), sizeof address);
  socklen_t length = sizeof address;
  ::getsockname(fd, reinterpret_cast<sockaddr*>(&address), &length);
  ::close(fd);
  return ntohs(address.sin_port);
}

class ClientTest : public ::testing::Test {
 protected:
  // No test inherits these from the environment it runs in.
  ScopedEnv no_manager_env_{"LN_MANAGER", std::nullopt};
  ScopedEnv no_program_name_{"LN_PROGRAM_NAME", std::nullopt};
  ScopedEnv no_topic_map_{"LN_MAP_TOPICS", std::nullopt};
  ScopedEnv no_debug_{"LN_DEBUG", std::nullopt};
  InProcessManager manager_;
};

TEST_F(ClientTest, ConnectsAndKeepsItsName) {
  ln_client client = nullptr;
  ASSERT_EQ(ln_init_to_manager(&client, "alpha", manager_.address().c_str()), 0);
  EXPECT_EQ(name_of(client), "alpha");
  double rtt = -1;
  EXPECT_EQ(ln_ping(client, 2.0, &rtt), 0);
  EXPECT_GT(rtt, 0);
  EXPECT_LT(rtt, 2.0);
  EXPECT_EQ(ln_ping(client, 0, &rtt), 0);
  EXPECT_EQ(ln_deinit(&client), 0);
  EXPECT_EQ(client, nullptr);
}

TEST_F(ClientTest, DuplicateNamesGetANumberExactNamesFail) {
  ln_client first = nullptr, second = nullptr, third = nullptr, exact = nullptr;
  ASSERT_EQ(ln_init_to_manager(&first, "dup", manager_.address().c_str()), 0);
  ASSERT_EQ(ln_init_to_manager(&second, "dup", manager_.address().c_str()), 0);
  ASSERT_EQ(ln_init_to_manager(&third, "dup", manager_.address().c_str()), 0);
  EXPECT_EQ(name_of(second), "dup 1");
  EXPECT_EQ(name_of(third), "dup 2");
  EXPECT_EQ(ln_init_to_manager(&exact, "exact:dup", manager_.address().c_str()), -LNE_CLNT_NAME_IN_USE);
  EXPECT_EQ(exact, nullptr);
  ASSERT_EQ(ln_init_to_manager(&exact, "exact:unique", manager_.address().c_str()), 0);
  EXPECT_EQ(name_of(exact), "unique");
  for (ln_client* c : {&first, &second, &third, &exact}) ln_deinit(c);
}

TEST_F(ClientTest, NameOverridesFromEnvironmentAndArguments) {
  ScopedEnv program_name("LN_PROGRAM_NAME", std::string("from_env"));
  ln_client client = nullptr;
  ASSERT_EQ(ln_init_to_manager(&client, "in_code", manager_.address().c_str()), 0);
  EXPECT_EQ(name_of(client), "from_env");
  ln_deinit(&client);

  const std::string address = manager_.address();
  std::vector<const char*> argv = {"prog", "--ln-manager", address.c_str(), "--ln-program-name", "from_arg", "x"};
  ASSERT_EQ(ln_init(&client, "in_code", static_cast<int>(argv.size()), const_cast<char**>(argv.data())), 0);
  EXPECT_EQ(name_of(client), "from_arg");
  ln_deinit(&client);

  // exact: ignores both overrides
  ASSERT_EQ(ln_init(&client, "exact:exactly", static_cast<int>(argv.size()), const_cast<char**>(argv.data())), 0);
  EXPECT_EQ(name_of(client), "exactly");
  ln_deinit(&client);
}

TEST_F(ClientTest, RemainingArgumentsKeepOrderAndArgv0) {
  const std::string address = manager_.address();
  std::vector<const char*> argv = {"./prog", "a", "-ln_manager", address.c_str(), "b", "--ln-map-topic", "x", "y", "c"};
  ln_client client = nullptr;
  ASSERT_EQ(ln_init(&client, "args", static_cast<int>(argv.size()), const_cast<char**>(argv.data())), 0);
  unsigned n = 0;
  char* block = nullptr;
  ASSERT_EQ(ln_get_remaining_args(client, &n, &block), 0);
  std::vector<std::string> args;
  for (unsigned i = 0; i < n; ++i) {
    args.emplace_back(block);
    block += args.back().size() + 1;
  }
  EXPECT_EQ(args, (std::vector<std::string>{"./prog", "a", "b", "c"}));
  ln_deinit(&client);
}

TEST_F(ClientTest, ArgumentAddressWinsOverLnManager) {
  const std::string wrong = "127.0.0.1:" + std::to_string(unused_port());
  ScopedEnv env("LN_MANAGER", wrong);
  const std::string address = manager_.address();
  std::vector<const char*> argv = {"prog", "--ln-manager", address.c_str()};
  ln_client client = nullptr;
  ASSERT_EQ(ln_init(&client, "arg_wins", static_cast<int>(argv.size()), const_cast<char**>(argv.data())), 0);
  ln_deinit(&client);
  ASSERT_EQ(ln_init_to_manager(&client, "explicit_wins", address.c_str()), 0);
  ln_deinit(&client);
  // Without an explicit address LN_MANAGER is used (and here refused).
  EXPECT_EQ(ln_init(&client, "env_used", 1, const_cast<char**>(argv.data())), -LNE_CHECK_ERRNO);
  ScopedEnv good_env("LN_MANAGER", address);
  ASSERT_EQ(ln_init(&client, "env_used", 1, const_cast<char**>(argv.data())), 0);
  ln_deinit(&client);
  ASSERT_EQ(ln_init_to_manager(&client, "env_used_too", nullptr), 0);
  ln_deinit(&client);
}

TEST_F(ClientTest, BadManagerAddressesFailWithLnsErrors) {
  ln_client client = nullptr;
  EXPECT_EQ(ln_init(&client, "x", 0, nullptr), -LNE_NO_MANAGER_ADDRESS);
  EXPECT_STREQ(ln_format_error(-LNE_NO_MANAGER_ADDRESS),
               "LNE_NO_MANAGER_ADDRESS - no --ln-manager HOST:PORT command line argument and no LN_MANAGER "
               "environment var");
  EXPECT_EQ(ln_init_to_manager(&client, "x", "no_colon"), -LNE_INVALID_MANAGER_ADDRESS);
  EXPECT_EQ(ln_init_to_manager(&client, "x", "localhost:port"), -LNE_INVALID_MANAGER_ADDRESS);
  EXPECT_EQ(ln_init_to_manager(&client, "x", ":1234"), -LNE_INVALID_HOSTNAME);
  EXPECT_EQ(ln_init_to_manager(&client, "x", "no-such-host.invalid:1234"), -LNE_UNKNOWN_HOSTNAME);
  const std::string refused = "127.0.0.1:" + std::to_string(unused_port());
  EXPECT_EQ(ln_init_to_manager(&client, "x", refused.c_str()), -LNE_CHECK_ERRNO);
  EXPECT_STREQ(ln_format_error(-LNE_CHECK_ERRNO), "errno 111 - Connection refused");
  EXPECT_EQ(client, nullptr);
  // without a client, ln_get_error_message(NULL) tells why the last ln_init* of this thread failed
  EXPECT_EQ(std::string(ln_get_error_message(nullptr)),
            "connecting to the ln_manager at " + refused + ": Connection refused");
  ::setenv("LN_MANAGER_CONNECT_TIMEOUT", "later", 1);
  EXPECT_EQ(ln_init_to_manager(&client, "x", refused.c_str()), -LNE_INVALID_PARAMETER);
  ::unsetenv("LN_MANAGER_CONNECT_TIMEOUT");
  EXPECT_STREQ(ln_get_error_message(nullptr),
               "LN_MANAGER_CONNECT_TIMEOUT='later' is not a number of seconds (0 to 1000000)");
  // a client that waits for the manager tries until the whole wait passed, and says it waited
  ::setenv("LN_MANAGER_CONNECT_TIMEOUT", "0.3", 1);
  const auto start = std::chrono::steady_clock::now();
  EXPECT_EQ(ln_init_to_manager(&client, "x", refused.c_str()), -LNE_CHECK_ERRNO);
  const std::chrono::duration<double> waited = std::chrono::steady_clock::now() - start;
  ::unsetenv("LN_MANAGER_CONNECT_TIMEOUT");
  EXPECT_GE(waited.count(), 0.3);
  EXPECT_EQ(std::string(ln_get_error_message(nullptr)), "connecting to the ln_manager at " + refused +
                                                            ": Connection refused (tried for 0.3 s, "
                                                            "LN_MANAGER_CONNECT_TIMEOUT)");
  EXPECT_STREQ(ln_format_error(-LNE_CHECK_ERRNO), "errno 111 - Connection refused");
}

TEST_F(ClientTest, InvalidHandlesAreRefused) {
  EXPECT_EQ(ln_ping(nullptr, 0, nullptr), -LNE_CLIENT_NOT_INITIALIZED);
  int not_a_client = 0;
  EXPECT_EQ(ln_ping(&not_a_client, 0, nullptr), -LNE_CLIENT_NOT_INITIALIZED);
  EXPECT_NE(ln_get_error_message(nullptr), nullptr) << "ln_core: the reason of the last failed ln_init*";
  ln_client none = nullptr;
  EXPECT_EQ(ln_deinit(&none), -LNE_CLIENT_NOT_INITIALIZED);
  EXPECT_EQ(ln_write(nullptr, nullptr, 0, nullptr), -LNE_INVALID_PORT_OBJECT);
  EXPECT_EQ(ln_read(nullptr, nullptr, 0, nullptr, 0), -LNE_INVALID_PORT_OBJECT);
  EXPECT_EQ(ln_get_message_size(nullptr), -LNE_INVALID_PORT_OBJECT);
  EXPECT_EQ(ln_get_library_version(), LN_LIBRARY_VERSION);
}

TEST_F(ClientTest, UnimplementedFunctionsExistAndSaySoAndBadSignaturesAreRefused) {
  ln_client client = nullptr;
  ASSERT_EQ(ln_init_to_manager(&client, "stubs", manager_.address().c_str()), 0);
  ln_service service = nullptr;
  EXPECT_EQ(ln_service_init(client, &service, "s", "i", "not a signature"), -LNE_INVALID_SIGNATURE);
  ln_logger logger = nullptr;  // implemented now (src/client/loggers_test.cpp)
  EXPECT_EQ(ln_client_get_logger(client, &logger, "l"), 0);
  ln_deinit(&client);
}

class DefinitionTest : public ClientTest {
 protected:
  void SetUp() override { ASSERT_EQ(ln_init_to_manager(&client_, "md", manager_.address().c_str()), 0); }
  void TearDown() override { ln_deinit(&client_); }
  ln_client client_ = nullptr;
};

TEST_F(DefinitionTest, GetMessageDefinitionGivesTextSizeHashAndFlatForm) {
  char* text = nullptr;
  char* hash = nullptr;
  char* flat = nullptr;
  unsigned size = 0;
  ASSERT_EQ(ln_get_message_definition_v21(client_, "test/pose", &text, &size, &hash, &flat), 0)
      << ln_get_error_message(client_);
  EXPECT_NE(std::string(text).find("define vec3 as \"test/vec3\""), std::string::npos);
  EXPECT_EQ(size, 4u + 24u + 32u + 48u);
  EXPECT_EQ(std::strlen(hash), 64u);
  EXPECT_EQ(std::string(flat),
            "7 4 1 counter|0 8 1 position_x|0 8 1 position_y|0 8 1 position_z|0 8 4 orientation|"
            "0 8 1 corners_x[0]|0 8 1 corners_y[0]|0 8 1 corners_z[0]|0 8 1 corners_x[1]|0 8 1 corners_y[1]|"
            "0 8 1 corners_z[1]|");
  std::free(text);
  std::free(hash);
  std::free(flat);

  ASSERT_EQ(ln_get_message_definition(client_, "test/p64", &text, &size), 0);
  EXPECT_EQ(size, 64u);
  std::free(text);

  EXPECT_EQ(ln_get_message_definition(client_, "test/missing", &text, &size), -LNE_REQUEST_FAILED);
  EXPECT_NE(std::string(ln_get_error_message(client_)).find("test/missing"), std::string::npos);
}

TEST_F(DefinitionTest, DescribeAndLocateMembers) {
  char* description = nullptr;
  ASSERT_EQ(ln_describe_message_definition(client_, "test/pose", &description), 0);
  const std::string text = description;
  std::free(description);
  EXPECT_NE(text.find("name: test/pose"), std::string::npos) << text;
  EXPECT_NE(text.find("  vec3 corners[2]  (offset 60, size 48)"), std::string::npos) << text;
  EXPECT_NE(text.find("name: test/vec3"), std::string::npos) << text;

  unsigned offset = 0, length = 0;
  ASSERT_EQ(ln_locate_member_in_message_definition(client_, "test/pose", "corners[1].y", &offset, &length), 0);
  EXPECT_EQ(offset, 60u + 24u + 8u);
  EXPECT_EQ(length, 8u);
  // Without an index: the first element (the definition model's rule).
  ASSERT_EQ(ln_locate_member_in_message_definition(client_, "test/pose", "orientation", &offset, &length), 0);
  EXPECT_EQ(offset, 28u);
  EXPECT_EQ(length, 8u);
  EXPECT_EQ(ln_locate_member_in_message_definition(client_, "test/pose", "nothing", &offset, &length),
            -LNE_INVALID_PARAMETER);
}

TEST_F(DefinitionTest, PutDefinitionThenPublishAndQueryByTopic) {
  char* real_name = nullptr;
  ASSERT_EQ(ln_put_message_definition(client_, "mine/counter", "uint32_t count\ndouble t\n", &real_name), 0)
      << ln_get_error_message(client_);
  const std::string stored = real_name;
  std::free(real_name);
  ln_outport port = nullptr;
  ASSERT_EQ(ln_publish(client_, "put.topic", stored.c_str(), &port), 0) << ln_get_error_message(client_);
  EXPECT_EQ(ln_get_message_size(port), 12);
  char* md_name = nullptr;
  char* text = nullptr;
  char* hash = nullptr;
  unsigned size = 0;
  ASSERT_EQ(ln_get_message_definition_for_topic_v17(client_, "put.topic", &md_name, &text, &size, &hash), 0);
  EXPECT_EQ(std::string(md_name), stored);
  EXPECT_EQ(std::string(text), "uint32_t count\ndouble t\n");
  EXPECT_EQ(size, 12u);
  EXPECT_STREQ(hash, ln_get_msg_def_hash(port));
  for (char* s : {md_name, text, hash}) std::free(s);
  EXPECT_EQ(ln_unpublish(&port), 0);
}

// The C++ wrapper is header-only over this library.
TEST_F(ClientTest, CppWrapperClientAndExceptions) {
  ln::client client("cpp", manager_.address());
  EXPECT_EQ(client.name, "cpp");
  EXPECT_GE(client.ping(2.0), 0.0);
  std::string text, hash, flat;
  unsigned size = 0;
  client.get_message_definition("test/p64", text, size, hash, flat);
  EXPECT_EQ(size, 64u);
  try {
    ln::client refused("refused", std::string("127.0.0.1:") + std::to_string(unused_port()));
    FAIL() << "connecting to nothing must throw";
  } catch (const ln::exception& e) {
    EXPECT_NE(std::string(e.what()).find("Connection refused"), std::string::npos) << e.what();
  }
}

}  // namespace
