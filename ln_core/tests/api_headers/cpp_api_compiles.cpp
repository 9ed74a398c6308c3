// Compile-only check of the C++ API that <ln/ln.h> pulls in (never linked or
// run). Pins LN 2.9's member types and method signatures with typed member
// pointers, the default arguments and the shapes generated code relies on
// by calling them, and the ln_core extensions.
#include <ln/ln.h>
#include <ln/packed.h>

#include <cstring>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#ifndef LN_CPPWRAPPER_H
#error "<ln/ln.h> must include the C++ wrapper in C++"
#endif

namespace {

template <typename Expected, typename Actual>
constexpr bool same() {
  return std::is_same<Expected, Actual>::value;
}

// ---- data members (types as in LN 2.9) ----
static_assert(std::is_base_of<std::exception, ln::exception>::value, "ln::exception is a std::exception");
static_assert(same<std::string, decltype(ln::exception::msg)>(), "exception::msg");
static_assert(same<ln_error_t, decltype(ln::exception::error)>(), "exception::error");
static_assert(same<int, decltype(ln::exception::error_code)>(), "exception::error_code");
static_assert(same<ln_client, decltype(ln::client::clnt)>(), "client::clnt");
static_assert(same<std::string, decltype(ln::client::name)>(), "client::name");
static_assert(same<ln::client*, decltype(ln::port_base::clnt)>(), "port_base::clnt");
static_assert(same<std::string, decltype(ln::port_base::topic_name)>(), "port_base::topic_name");
static_assert(same<std::string, decltype(ln::port_base::topic_md)>(), "port_base::topic_md");
static_assert(same<unsigned int, decltype(ln::port_base::message_size)>(), "port_base::message_size");
static_assert(same<std::string, decltype(ln::port_base::msg_def_hash)>(), "port_base::msg_def_hash");
static_assert(std::is_base_of<ln::port_base, ln::outport>::value, "outport is a port");
static_assert(std::is_base_of<ln::port_base, ln::inport>::value, "inport is a port");
static_assert(same<ln_outport, decltype(ln::outport::port)>(), "outport::port");
static_assert(same<ln_inport, decltype(ln::inport::port)>(), "inport::port");
static_assert(same<double, decltype(ln::inport::timestamp)>(), "inport::timestamp");
static_assert(same<ln::client*, decltype(ln::multi_waiter::clnt)>(), "multi_waiter::clnt");
static_assert(same<ln_multi_waiter, decltype(ln::multi_waiter::waiter)>(), "multi_waiter::waiter");
static_assert(same<ln::client*, decltype(ln::service::clnt)>(), "service::clnt (generated code)");
static_assert(same<ln_service, decltype(ln::service::svc)>(), "service::svc");
static_assert(same<ln::service*, decltype(ln::service_request::svc)>(), "service_request::svc");
static_assert(same<ln::event_connection*, decltype(ln::event_call::connection)>(), "event_call::connection");
static_assert(same<ln_event_call&, decltype(ln::event_call::call)>(), "event_call::call");
static_assert(same<unsigned int, decltype(ln::event_connection::id)>(), "event_connection::id");
static_assert(same<ln_logger, decltype(ln::logger::_logger)>(), "logger::_logger");
static_assert(same<ln::logger_data*, decltype(ln::logger::data)>(), "logger::data");
static_assert(same<ln_logger_data, decltype(ln::logger_data::data)>(), "logger_data::data");
static_assert(same<std::list<ln::logger_data::topic_cursor*>, ln::logger_data::topics_t>(), "topics_t");
static_assert(same<int (*)(ln::client&, ln::service_request&, void*), ln::service::handler_t>(), "service::handler_t");
static_assert(same<void (*)(ln::client&, ln_svc_client_event_t, int, void*), ln::service::fd_handler_t>(),
              "service::fd_handler_t");
static_assert(same<void (*)(ln::event_call&, void*), ln::event_connection::handler_t>(), "event_connection::handler_t");

// ---- ownership: handles are not copyable; extension results move ----
static_assert(!std::is_copy_constructible<ln::client>::value, "client is not copyable");
static_assert(!std::is_copy_constructible<ln::service>::value, "service is not copyable");
static_assert(!std::is_copy_constructible<ln::string_buffer>::value, "string_buffer is not copyable");
static_assert(!std::is_copy_constructible<ln::borrowed_sample>::value, "borrowed_sample is move-only");
static_assert(std::is_nothrow_move_constructible<ln::borrowed_sample>::value, "borrowed_sample moves");
static_assert(!std::is_copy_constructible<ln::service_future>::value, "service_future is move-only");
static_assert(std::is_nothrow_move_constructible<ln::service_future>::value, "service_future moves");
static_assert(same<ln_sample_info, ln::sample_info>(), "sample_info is the C struct");

// ---- constructors ----
static_assert(std::is_constructible<ln::client, std::string>::value, "client(name)");
static_assert(std::is_constructible<ln::client, std::string, int, char**>::value, "client(name, argc, argv)");
static_assert(std::is_constructible<ln::client, std::string, std::string>::value, "client(name, manager)");
static_assert(std::is_constructible<ln::client, ln_client>::value, "client(ln_client)");

}  // namespace

// ---- method signatures (LN 2.9) ----
namespace {
// Only compiles if &member converts to exactly this pointer type.
template <typename Expected>
void expect_type(Expected) {}
}  // namespace
#define CHECK_METHOD(type, member) expect_type<type>(&member)

void cpp_api_signatures();
void cpp_api_signatures() {
  using ln::client;
  using std::string;
  CHECK_METHOD(std::vector<string>(client::*)(), client::get_remaining_args);
  CHECK_METHOD(double(client::*)(double), client::ping);
  CHECK_METHOD(string(client::*)(string), client::describe_message_definition);
  CHECK_METHOD(string(client::*)(string, string), client::put_message_definition);
  CHECK_METHOD(void(client::*)(string, string&, string&, string&), client::get_service_signature_for_service);
  CHECK_METHOD(void(client::*)(string, string&, string&), client::get_service_signature);
  CHECK_METHOD(void(client::*)(string, string, unsigned int&, unsigned int&),
               client::locate_member_in_message_definition);
  CHECK_METHOD(ln::outport * (client::*)(string, string, unsigned int), client::publish);
  CHECK_METHOD(void(client::*)(ln::outport*), client::unpublish);
  CHECK_METHOD(ln::inport * (client::*)(string, string, double, unsigned int, bool), client::subscribe);
  CHECK_METHOD(void(client::*)(ln::inport*), client::unsubscribe);
  CHECK_METHOD(ln::multi_waiter * (client::*)(), client::get_multi_waiter);
  CHECK_METHOD(void(client::*)(const char*, double), client::wait_and_handle_service_group_requests);
  CHECK_METHOD(void(client::*)(const char*, string), client::handle_service_group_in_thread_pool);
  CHECK_METHOD(void(client::*)(const char*), client::remove_service_group_from_thread_pool);
  CHECK_METHOD(void(client::*)(const char*), client::unblock_service_group);
  CHECK_METHOD(void(client::*)(string, unsigned int), client::set_max_threads);
  CHECK_METHOD(void(client::*)(string, int, int, unsigned int), client::thread_pool_setschedparam);
  CHECK_METHOD(ln::service * (client::*)(string, string, string), client::get_service);
  CHECK_METHOD(ln::service * (client::*)(string, string, string), client::get_service_provider);
  CHECK_METHOD(void(client::*)(ln::service*), client::release_service);
  CHECK_METHOD(void(client::*)(string, double), client::needs_provider);
  CHECK_METHOD(ln::logger * (client::*)(string), client::get_logger);
  CHECK_METHOD(string(client::*)(string), client::find_services_with_interface);
  CHECK_METHOD(ln::event_connection * (client::*)(string, string, void*, ln::event_connection::handler_t, void*),
               client::connect_to_event);
  CHECK_METHOD(
      ln::event_connection * (client::*)(string, string, void*, uint32_t, ln::event_connection::handler_t, void*),
      client::connect_to_event_flat);
  CHECK_METHOD(void(client::*)(ln::event_connection*), client::disconnect_from_event);
  CHECK_METHOD(void(client::*)(bool), client::set_thread_safe);
  CHECK_METHOD(void(client::*)(string, string), client::register_as_service_logger);
  CHECK_METHOD(void(client::*)(string, float), client::set_float_parameter);
  CHECK_METHOD(ln::parameters::parameter_proxy(client::*)(string, bool), client::get_parameters);

  CHECK_METHOD(void* (ln::outport::*)(unsigned int*), ln::outport::get_next_buffer);
  CHECK_METHOD(unsigned int (ln::outport::*)(), ln::outport::has_subscriber);
  CHECK_METHOD(bool(ln::inport::*)(), ln::inport::has_publisher);
  CHECK_METHOD(void(ln::inport::*)(), ln::inport::unblock);
  CHECK_METHOD(void(ln::multi_waiter::*)(ln::inport*), ln::multi_waiter::add_port);
  CHECK_METHOD(void(ln::multi_waiter::*)(ln::inport*), ln::multi_waiter::remove_port);
  CHECK_METHOD(bool(ln::multi_waiter::*)(double), ln::multi_waiter::wait);
  CHECK_METHOD(bool(ln::multi_waiter::*)(ln::inport*), ln::multi_waiter::can_read);
  CHECK_METHOD(int(ln::multi_waiter::*)(ln_pipe_fd_t*), ln::multi_waiter::start_pipe_notifier_thread);
  CHECK_METHOD(int(ln::multi_waiter::*)(), ln::multi_waiter::ack_pipe_notification);

  CHECK_METHOD(void(ln::service::*)(ln::service::handler_t, void*), ln::service::set_handler);
  CHECK_METHOD(void(ln::service::*)(const char*), ln::service::do_register);
  CHECK_METHOD(int(ln::service::*)(), ln::service::get_fd);
  CHECK_METHOD(void(ln::service::*)(ln::service::fd_handler_t, void*), ln::service::set_client_fd_handler);
  CHECK_METHOD(void(ln::service::*)(void*, double), ln::service::call);
  CHECK_METHOD(void(ln::service::*)(struct iovec*, unsigned int, uint8_t*, char**, uint32_t*, uint8_t*, double),
               ln::service::callv);
  CHECK_METHOD(void(ln::service::*)(), ln::service::abort);
  CHECK_METHOD(ln::service_request * (ln::service::*)(void*), ln::service::call_async);
  CHECK_METHOD(ln::service_request * (ln::service::*)(struct iovec*, unsigned int, uint8_t*), ln::service::callv_async);
  CHECK_METHOD(void(ln::service::*)(char**, uint32_t*), ln::service::callv_async_get_response);
  CHECK_METHOD(void(ln::service::*)(void*), ln::service::callv_async_get_response_data);

  CHECK_METHOD(void(ln::service_request::*)(void*, const char*), ln::service_request::set_data);
  CHECK_METHOD(void(ln::service_request::*)(char**, uint64_t*), ln::service_request::get_request_data);
  CHECK_METHOD(int(ln::service_request::*)(), ln::service_request::respond);
  CHECK_METHOD(int(ln::service_request::*)(struct iovec*, unsigned int), ln::service_request::respondv);
  CHECK_METHOD(int(ln::service_request::*)(void*), ln::service_request::respond_data);
  CHECK_METHOD(bool(ln::service_request::*)(), ln::service_request::is_aborted);
  CHECK_METHOD(bool(ln::service_request::*)(), ln::service_request::finished);
  CHECK_METHOD(void(ln::service_request::*)(), ln::service_request::abort);
  CHECK_METHOD(int(ln::service_request::*)(), ln::service_request::get_finished_notification_fd);

  CHECK_METHOD(void(ln::event_call::*)(void*, const char*), ln::event_call::set_data);
  CHECK_METHOD(void* (ln::event_call::*)(uint32_t*), ln::event_call::get_buffer);

  CHECK_METHOD(void(ln::logger::*)(string, uint64_t, unsigned int), ln::logger::add_topic);
  CHECK_METHOD(void(ln::logger::*)(), ln::logger::clear_topics);
  CHECK_METHOD(void(ln::logger::*)(), ln::logger::enable);
  CHECK_METHOD(void(ln::logger::*)(), ln::logger::disable);
  CHECK_METHOD(ln::logger_data * (ln::logger::*)(), ln::logger::download);
  CHECK_METHOD(ln::logger_data * (ln::logger::*)(), ln::logger::direct_download);
  CHECK_METHOD(void(ln::logger::*)(string, string), ln::logger::manager_save);
  CHECK_METHOD(void(ln::logger::*)(bool), ln::logger::set_only_ts);
  CHECK_METHOD(void(ln::logger_data::*)(string), ln::logger_data::save);
  CHECK_METHOD(ln::logger_data * (*)(string), ln::logger_data::load);
  CHECK_METHOD(logger_sample * (ln::logger_data::topic_cursor::*)(unsigned int),
               ln::logger_data::topic_cursor::get_sample);

  CHECK_METHOD(string(*)(const string&, const string&), ln::dsa_dss1_sign_message);
  CHECK_METHOD(bool (*)(const string&, const string&, const string&), ln::dsa_dss1_verify_message_signature);
  CHECK_METHOD(bool (*)(const string&, const string&, const string&), ln::dsa_dss1_verify_message_signature_memkey);
  CHECK_METHOD(void (*)(const string&, const string&), ln::dsa_dss1_generate_key_pair);

  // ln_core extensions
  CHECK_METHOD(bool(client::*)(const string&, double), client::wait_for_service);
  CHECK_METHOD(void(client::*)(const string&, client::availability_handler_t),
               client::set_service_availability_handler);
  CHECK_METHOD(void(client::*)(const string&, client::availability_handler_t),
               client::set_publisher_availability_handler);
  CHECK_METHOD(ln::borrowed_sample(ln::inport::*)(double), ln::inport::borrow);
  CHECK_METHOD(ln::service_future(ln::service::*)(void*), ln::service::call_future);
  CHECK_METHOD(void(ln::service_request::*)(int, const string&), ln::service_request::respond_error);
  CHECK_METHOD(bool(ln::service_request::*)(double), ln::service_request::wait);
  CHECK_METHOD(std::vector<ln::topic_info>(client::*)(), client::list_topics);
  CHECK_METHOD(std::vector<ln::client_info>(client::*)(), client::list_clients);
  CHECK_METHOD(std::vector<ln::service_info>(client::*)(), client::list_services);
  CHECK_METHOD(ln::manager_status(client::*)(), client::get_manager_status);
}

// ---- calls with default arguments and the shapes generated code uses ----
namespace {
int provider_handler(ln::client& clnt, ln::service_request& req, void* user_data) {
  (void)clnt;
  (void)user_data;
  char buffer[16];
  req.set_data(buffer, "int32_t 4 1|int32_t 4 1");
  if (req.is_aborted()) return 0;
  return req.respond();
}

void event_handler(ln::event_call& call, void* user_data) {
  (void)user_data;
  char buffer[16];
  call.set_data(buffer, "sig");
  uint32_t len = 0;
  (void)call.get_buffer(&len);
}

void fd_handler(ln::client& clnt, ln_svc_client_event_t event, int fd, void* user_data) {
  (void)clnt;
  (void)event;
  (void)fd;
  (void)user_data;
}
}  // namespace

void cpp_api_usage(int argc, char* argv[]);
void cpp_api_usage(int argc, char* argv[]) {
  ln::client by_name("name");
  ln::client by_argv(argv[0], argc, argv);
  ln::client by_manager("name", "localhost:54123");
  ln::client wrapped(by_name.clnt);
  ln::client by_char_pointer(argv[0]);  // must not pick client(ln_client)

  std::vector<std::string> rest = by_name.get_remaining_args();
  (void)by_name.ping();
  std::string md, md_name, hash, flat;
  unsigned int size = 0, offset = 0, len = 0;
  by_name.get_message_definition("a/b", md, size, hash, flat);
  by_name.get_message_definition("a/b", md, size, hash);
  by_name.get_message_definition("a/b", md, size);
  by_name.get_message_definition_for_topic("t", md_name, md, size, hash);
  by_name.get_message_definition_for_topic("t", md_name, md, size);
  by_name.locate_member_in_message_definition("a/b", "x[2]", offset, len);

  ln::outport* out = by_name.publish("t", "a/b");
  out->write(nullptr);
  out->write(nullptr, ln_get_time());
  (void)out->has_subscriber();
  ln::inport* in = by_name.subscribe("t", "a/b");
  ln::inport* sparse = by_name.subscribe("t", "a/b", RATE_ON_REQUEST_LAST, 3, true);
  char packet[8];
  (void)in->read(packet);
  (void)in->read(packet, false);
  (void)in->read(packet, 0.5);
  (void)sparse->timestamp;

  ln::multi_waiter* waiter = by_name.get_multi_waiter();
  waiter->add_port(in);
  if (waiter->wait() && waiter->can_read(in)) (void)in->read(packet, false);
  (void)waiter->wait(0.1);

  ln::service* provider = by_name.get_service_provider("svc", "a/svc", "int32_t 4 1|int32_t 4 1");
  provider->set_handler(&provider_handler);
  provider->set_handler(&provider_handler, nullptr);
  provider->set_client_fd_handler(&fd_handler);
  provider->do_register();
  provider->do_register("group");
  provider->clnt->release_service(provider);  // as generated base classes do
  by_name.wait_and_handle_service_group_requests(nullptr);
  by_name.wait_and_handle_service_group_requests(nullptr, 0.5);
  by_name.handle_service_group_in_thread_pool("group", "pool");
  by_name.set_max_threads("pool", 2);
  by_name.thread_pool_setschedparam("pool");

  ln::service* caller = by_name.get_service("svc", "a/svc", "int32_t 4 1|int32_t 4 1");
  char data[8] = {};
  caller->call(data);
  caller->call(data, 1.0);
  ln::service_request* pending = caller->call_async(data);
  while (!pending->finished()) {
  }
  by_name.needs_provider("svc");

  ln::event_connection* events = by_name.connect_to_event("e", "sig", nullptr, &event_handler);
  by_name.disconnect_from_event(events);
  ln::logger* recorder = by_name.get_logger("l");
  recorder->add_topic("t", 100);
  recorder->manager_save("file");
  ln::logger_data* recorded = recorder->download();
  for (ln::logger_data::topic_iterator i = recorded->topics.begin(); i != recorded->topics.end(); ++i)
    (void)(*i)->get_sample(0);
  delete ln::logger_data::load("file");

  // string_buffer sets a generated char* field and the uint32_t _len field
  // packed right before it, so it needs that layout, not a lone pointer.
  struct LN_PACKED {
    uint32_t text_len;
    char* text;
  } field = {0, nullptr};
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Waddress-of-packed-member"  // LN's API takes the field's address
  ln::string_buffer owned(&field.text, std::string("hello"));
#pragma GCC diagnostic pop
  std::string back = owned;
  (void)owned.c_str();

  ln::mutex_t mutex;
  { ln::mutex_holder hold(mutex); }

  try {
    by_name.throw_error(-LNE_INVALID_PARAMETER, "bad value %d", 3);
  } catch (const ln::exception& e) {
    (void)e.what();
    (void)(e.error == LNE_INVALID_PARAMETER);
    (void)e.error_code;
  }

  // ln_core extensions
  ln::sample_info info{};
  (void)in->read(packet, -1.0, &info);
  if (ln::borrowed_sample sample = in->borrow(0.1)) {
    (void)sample.data();
    (void)sample.size();
    (void)sample.info().sequence;
    (void)sample.as<double>();
    ln::borrowed_sample moved = std::move(sample);
    moved.release();
  }
  ln::service_future future = caller->call_future(data);
  if (future.wait_for(0.5)) future.get();
  ln::service_future other = std::move(future);
  (void)other.valid();
  (void)by_name.wait_for_service("svc", 2.0);
  by_name.set_service_availability_handler("svc", [](const std::string& name, bool up) {
    (void)name;
    (void)up;
  });
  by_name.set_publisher_availability_handler("t", nullptr);
  by_name.unsubscribe(in);
  by_name.unpublish(out);
}
