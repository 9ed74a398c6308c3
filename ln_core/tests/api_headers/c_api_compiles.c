/* Compile-only check of the C API in <ln/ln.h> (never linked or run).
 *
 * Pins the contract: every LN 2.9 function keeps its exact type (a typed
 * function pointer initialised with it fails to compile otherwise), the
 * LNE_* codes keep LN 2.9's values, and a typical C program compiles. Also
 * compiled as C++ with NO_CPP_WRAPPER (c_api_as_cpp.cpp). */
#include <ln/ln.h>

#include <stddef.h>
#include <stdlib.h>
#include <string.h>

#if defined(__cplusplus)
#define LN_STATIC_ASSERT(condition, what) static_assert(condition, what)
#elif defined(__STDC_VERSION__) && __STDC_VERSION__ >= 201112L
#define LN_STATIC_ASSERT(condition, what) _Static_assert(condition, what)
#else /* C99: a negative array size fails; the line number keeps names unique */
#define LN_JOIN_(a, b) a##b
#define LN_JOIN(a, b) LN_JOIN_(a, b)
#define LN_STATIC_ASSERT(condition, what) typedef char LN_JOIN(ln_static_assert_line_, __LINE__)[(condition) ? 1 : -1]
#endif

/* ---- constants and error codes (LN 2.9 values) ---- */
LN_STATIC_ASSERT(LN_LIBRARY_VERSION == 32, "API level of LN 2.9");
LN_STATIC_ASSERT(RATE_AS_PUBLISHED == -1, "RATE_AS_PUBLISHED");
LN_STATIC_ASSERT(RATE_ON_REQUEST_LAST == -2, "RATE_ON_REQUEST_LAST");
LN_STATIC_ASSERT(RATE_ON_REQUEST_NEXT == -3, "RATE_ON_REQUEST_NEXT");
LN_STATIC_ASSERT(LN_CORE_EXTENSIONS >= 1, "ln_core extensions announced");
LN_STATIC_ASSERT(LNE_CHECK_ERRNO == 1, "LNE_CHECK_ERRNO");
LN_STATIC_ASSERT(LNE_NO_MEM == 2, "LNE_NO_MEM");
LN_STATIC_ASSERT(LNE_NO_MANAGER_ADDRESS == 3, "LNE_NO_MANAGER_ADDRESS");
LN_STATIC_ASSERT(LNE_INVALID_MANAGER_ADDRESS == 4, "LNE_INVALID_MANAGER_ADDRESS");
LN_STATIC_ASSERT(LNE_INVALID_HOSTNAME == 5, "LNE_INVALID_HOSTNAME");
LN_STATIC_ASSERT(LNE_UNKNOWN_HOSTNAME == 6, "LNE_UNKNOWN_HOSTNAME");
LN_STATIC_ASSERT(LNE_HOST_WRONG_NET == 7, "LNE_HOST_WRONG_NET");
LN_STATIC_ASSERT(LNE_GOT_INVALID_RESPONSE == 8, "LNE_GOT_INVALID_RESPONSE");
LN_STATIC_ASSERT(LNE_REGISTER_DENIED == 9, "LNE_REGISTER_DENIED");
LN_STATIC_ASSERT(LNE_CLIENT_NOT_INITIALIZED == 10, "LNE_CLIENT_NOT_INITIALIZED");
LN_STATIC_ASSERT(LNE_REQUEST_FAILED == 11, "LNE_REQUEST_FAILED");
LN_STATIC_ASSERT(LNE_FIELD_NOT_IN_HEADER == 12, "LNE_FIELD_NOT_IN_HEADER");
LN_STATIC_ASSERT(LNE_STRING_LENGTH_SPEC_MISSING == 13, "LNE_STRING_LENGTH_SPEC_MISSING");
LN_STATIC_ASSERT(LNE_PORT_NOT_FOUND == 14, "LNE_PORT_NOT_FOUND");
LN_STATIC_ASSERT(LNE_INVALID_PORT_OBJECT == 15, "LNE_INVALID_PORT_OBJECT");
LN_STATIC_ASSERT(LNE_SHM_IS_TOO_SMALL == 16, "LNE_SHM_IS_TOO_SMALL");
LN_STATIC_ASSERT(LNE_SHM_IS_TOO_BIG == 17, "LNE_SHM_IS_TOO_BIG");
LN_STATIC_ASSERT(LNE_SHM_DOES_NOT_EXIT == 18, "LNE_SHM_DOES_NOT_EXIT");
LN_STATIC_ASSERT(LNE_PACKET_TOO_LARGE == 19, "LNE_PACKET_TOO_LARGE");
LN_STATIC_ASSERT(LNE_SHM_READ_ERROR == 20, "LNE_SHM_READ_ERROR");
LN_STATIC_ASSERT(LNE_LOST_CONNECTION == 21, "LNE_LOST_CONNECTION");
LN_STATIC_ASSERT(LNE_REGISTER_FAILED == 22, "LNE_REGISTER_FAILED");
LN_STATIC_ASSERT(LNE_SVC_IS_PROVIDER == 23, "LNE_SVC_IS_PROVIDER");
LN_STATIC_ASSERT(LNE_SVC_IS_CLIENT == 24, "LNE_SVC_IS_CLIENT");
LN_STATIC_ASSERT(LNE_SVC_RECV_RESP == 25, "LNE_SVC_RECV_RESP");
LN_STATIC_ASSERT(LNE_SVC_RECV_RESP_MEM == 26, "LNE_SVC_RECV_RESP_MEM");
LN_STATIC_ASSERT(LNE_SVC_ALREADY_REGISTERED == 27, "LNE_SVC_ALREADY_REGISTERED");
LN_STATIC_ASSERT(LNE_SVC_NOT_REGISTERED == 28, "LNE_SVC_NOT_REGISTERED");
LN_STATIC_ASSERT(LNE_SVC_RECV_REQ == 29, "LNE_SVC_RECV_REQ");
LN_STATIC_ASSERT(LNE_SVC_RECV_REQ_MEM == 30, "LNE_SVC_RECV_REQ_MEM");
LN_STATIC_ASSERT(LNE_SVC_REQ_SET_DATA_WRONG == 31, "LNE_SVC_REQ_SET_DATA_WRONG");
LN_STATIC_ASSERT(LNE_SVC_HANDLER_NO_RESP == 32, "LNE_SVC_HANDLER_NO_RESP");
LN_STATIC_ASSERT(LNE_INVALID_REQ_FIELD_FORMAT == 33, "LNE_INVALID_REQ_FIELD_FORMAT");
LN_STATIC_ASSERT(LNE_USER_DEFINED_ERROR == 34, "LNE_USER_DEFINED_ERROR");
LN_STATIC_ASSERT(LNE_SVC_NO_HANDLER == 35, "LNE_SVC_NO_HANDLER");
LN_STATIC_ASSERT(LNE_SVC_HANDLER_EXC == 36, "LNE_SVC_HANDLER_EXC");
LN_STATIC_ASSERT(LNE_SVC_REQ_RUNNING == 37, "LNE_SVC_REQ_RUNNING");
LN_STATIC_ASSERT(LNE_SVC_REQ_NOT_RUNNING == 38, "LNE_SVC_REQ_NOT_RUNNING");
LN_STATIC_ASSERT(LNE_SVC_REQ_ABORTED == 39, "LNE_SVC_REQ_ABORTED");
LN_STATIC_ASSERT(LNE_NO_PROVIDER_FOUND == 40, "LNE_NO_PROVIDER_FOUND");
LN_STATIC_ASSERT(LNE_START_PROVIDER_FAILED == 41, "LNE_START_PROVIDER_FAILED");
LN_STATIC_ASSERT(LNE_ERROR_GETTING_SHM_FD == 42, "LNE_ERROR_GETTING_SHM_FD");
LN_STATIC_ASSERT(LNE_SHM_NAME_TOO_LONG == 43, "LNE_SHM_NAME_TOO_LONG");
LN_STATIC_ASSERT(LNE_NOT_YET_IMPLEMENTED == 44, "LNE_NOT_YET_IMPLEMENTED");
LN_STATIC_ASSERT(LNE_NO_LOGGER_TOPICS == 45, "LNE_NO_LOGGER_TOPICS");
LN_STATIC_ASSERT(LNE_INTERNAL_ERROR == 46, "LNE_INTERNAL_ERROR");
LN_STATIC_ASSERT(LNE_TOPIC_ID_OUT_OF_RANGE == 47, "LNE_TOPIC_ID_OUT_OF_RANGE");
LN_STATIC_ASSERT(LNE_LOG_FILE_TOO_NEW == 48, "LNE_LOG_FILE_TOO_NEW");
LN_STATIC_ASSERT(LNE_WRONG_BYTE_ORDER == 49, "LNE_WRONG_BYTE_ORDER");
LN_STATIC_ASSERT(LNE_INVALID_SHM_MAGIC == 50, "LNE_INVALID_SHM_MAGIC");
LN_STATIC_ASSERT(LNE_SHM_VERSION_TOO_NEW == 51, "LNE_SHM_VERSION_TOO_NEW");
LN_STATIC_ASSERT(LNE_WRONG_SHM_SIZE == 52, "LNE_WRONG_SHM_SIZE");
LN_STATIC_ASSERT(LNE_INVALID_SIGNATURE == 53, "LNE_INVALID_SIGNATURE");
LN_STATIC_ASSERT(LNE_INVALID_PARAMETER == 54, "LNE_INVALID_PARAMETER");
LN_STATIC_ASSERT(LNE_SVC_RESP_LATER == 55, "LNE_SVC_RESP_LATER");
LN_STATIC_ASSERT(LNE_SVC_GRP_UNKNOWN == 56, "LNE_SVC_GRP_UNKNOWN");
LN_STATIC_ASSERT(LNE_THREADP_INIT == 57, "LNE_THREADP_INIT");
LN_STATIC_ASSERT(LNE_NOT_ON_THIS_OS == 58, "LNE_NOT_ON_THIS_OS");
LN_STATIC_ASSERT(LNE_PORT_UNBLOCKED == 59, "LNE_PORT_UNBLOCKED");
LN_STATIC_ASSERT(LNE_UNKNOWN_PARAMETER == 60, "LNE_UNKNOWN_PARAMETER");
LN_STATIC_ASSERT(LNE_SVC_HANDLER_MULTI_RESP == 61, "LNE_SVC_HANDLER_MULTI_RESP");
LN_STATIC_ASSERT(LNE_MANAGER_TOO_OLD == 62, "LNE_MANAGER_TOO_OLD");
LN_STATIC_ASSERT(LNE_INVALID_DSA_SIGNATURE == 63, "LNE_INVALID_DSA_SIGNATURE");
LN_STATIC_ASSERT(LNE_SVC_TIMEOUT == 64, "LNE_SVC_TIMEOUT");
LN_STATIC_ASSERT(LNE_SVC_GRP_HANDLED_IN_POOL == 65, "LNE_SVC_GRP_HANDLED_IN_POOL");
LN_STATIC_ASSERT(LNE_CLNT_NAME_IN_USE == 66, "LNE_CLNT_NAME_IN_USE");
LN_STATIC_ASSERT(LNE_CHECK_ERROR_CODE == 67, "LNE_CHECK_ERROR_CODE");
LN_STATIC_ASSERT(LNE_UNKNOWN == 68, "LNE_UNKNOWN");
LN_STATIC_ASSERT(LNE_WRONG_MD_HASH == 69, "LNE_WRONG_MD_HASH");
LN_STATIC_ASSERT(sizeof(logger_sample) == 2 * sizeof(double) + sizeof(uint32_t) + 1, "logger_sample is packed");
LN_STATIC_ASSERT(sizeof(ln_sample_info) == 2 * sizeof(uint64_t) + sizeof(double), "ln_sample_info layout");

/* ---- exact function types ---- */
#define CHECK(ret, name, params)    \
  ret(*check_##name) params = name; \
  (void)check_##name

void c_api_signatures(void);
void c_api_signatures(void) {
  /* LN 2.9 */
  CHECK(int, create_shm_target, (shm_target_t*, const char*, unsigned int, unsigned int, unsigned int));
  CHECK(int, destroy_shm_target, (shm_target_t*));
  CHECK(int, open_shm_target, (shm_target_t*, const char*));
  CHECK(int, close_shm_target, (shm_target_t*));
  CHECK(int, write_to_shm_target, (shm_target_t, double, void*, unsigned int));
  CHECK(int, get_next_buffer_from_shm_target, (shm_target_t, void**));
  CHECK(int, create_shm_source, (shm_source_t*, const char*, unsigned int, unsigned int, unsigned int));
  CHECK(int, destroy_shm_source, (shm_source_t*));
  CHECK(int, open_shm_source, (shm_source_t*, const char*));
  CHECK(int, shm_source_get_last_counter, (shm_source_t*, uint32_t*));
  CHECK(int, close_shm_source, (shm_source_t*));
  CHECK(int, read_from_shm_source, (shm_source_t, double*, uint32_t*, void*, unsigned int, int));
  CHECK(int, read_from_shm_source_timeout, (shm_source_t, double*, uint32_t*, void*, unsigned int, double));
  CHECK(int, read_last_from_shm_source, (shm_source_t, double*, uint32_t*, void*, unsigned int));
  CHECK(int, block_only_on_shm_source, (shm_source_t, uint32_t*, double));
  CHECK(int, unblock_shm_source, (shm_source_t));
  CHECK(double, ln_get_time, (void));
  CHECK(double, ln_get_monotonic_time, (void));
  CHECK(void, ln_sleep_seconds, (double));
  CHECK(const char*, ln_format_error, (int));
  CHECK(int, ln_init, (ln_client*, const char*, int, char**));
  CHECK(int, ln_init_to_manager, (ln_client*, const char*, const char*));
  CHECK(int, ln_client_get_name, (ln_client, char**));
  CHECK(int, ln_deinit, (ln_client*));
  CHECK(void, ln_debug, (ln_client, const char*, ...));
  CHECK(int, ln_ping, (ln_client, double, double*));
  CHECK(int, ln_client_set_thread_safe, (ln_client, int));
  CHECK(int, ln_get_remaining_args, (ln_client, unsigned int*, char**));
  CHECK(char*, ln_get_error_message, (ln_client));
  CHECK(int, ln_get_message_definition_for_topic, (ln_client, const char*, char**, char**, unsigned int*));
  CHECK(int, ln_get_message_definition_for_topic_v17, (ln_client, const char*, char**, char**, unsigned int*, char**));
  CHECK(int, ln_get_message_definition, (ln_client, const char*, char**, unsigned int*));
  CHECK(int, ln_get_message_definition_v17, (ln_client, const char*, char**, unsigned int*, char**));
  CHECK(int, ln_get_message_definition_v21, (ln_client, const char*, char**, unsigned int*, char**, char**));
  CHECK(int, ln_describe_message_definition, (ln_client, const char*, char**));
  CHECK(int, ln_locate_member_in_message_definition,
        (ln_client, const char*, const char*, unsigned int*, unsigned int*));
  CHECK(int, ln_put_message_definition, (ln_client, const char*, const char*, char**));
  CHECK(int, ln_needs_provider, (ln_client, const char*, double));
  CHECK(int, ln_subscribe, (ln_client, const char*, const char*, ln_inport*, double, int));
  CHECK(int, ln_subscribe_with_buffers, (ln_client, const char*, const char*, ln_inport*, double, int, unsigned int));
  CHECK(int, ln_unsubscribe, (ln_inport*));
  CHECK(int, ln_has_publisher, (ln_inport));
  CHECK(int, ln_read, (ln_inport, void*, unsigned int, double*, int));
  CHECK(int, ln_read_timeout, (ln_inport, void*, unsigned int, double*, double));
  CHECK(int, ln_unblock, (ln_inport));
  CHECK(int, ln_publish, (ln_client, const char*, const char*, ln_outport*));
  CHECK(int, ln_publish_with_buffers, (ln_client, const char*, const char*, unsigned int, ln_outport*));
  CHECK(int, ln_unpublish, (ln_outport*));
  CHECK(int, ln_has_subscriber, (ln_outport));
  CHECK(int, ln_write, (ln_outport, void*, unsigned int, double*));
  CHECK(int, ln_outport_get_next_buffer, (ln_outport, void**, unsigned int*));
  CHECK(int, ln_get_message_size, (void*));
  CHECK(const char*, ln_get_msg_def_hash, (void*));
  CHECK(int, ln_multi_waiter_init, (ln_client, ln_multi_waiter*));
  CHECK(int, ln_multi_waiter_deinit, (ln_multi_waiter*));
  CHECK(int, ln_multi_waiter_add_port, (ln_multi_waiter, ln_inport));
  CHECK(int, ln_multi_waiter_remove_port, (ln_multi_waiter, ln_inport));
  CHECK(int, ln_multi_waiter_wait, (ln_multi_waiter, double));
  CHECK(int, ln_multi_waiter_can_read, (ln_multi_waiter, ln_inport));
  CHECK(int, ln_multi_waiter_start_pipe_notifier_thread, (ln_multi_waiter, ln_pipe_fd_t*));
  CHECK(int, ln_multi_waiter_ack_pipe_notification, (ln_multi_waiter));
  CHECK(int, ln_service_init, (ln_client, ln_service*, const char*, const char*, const char*));
  CHECK(int, ln_service_deinit, (ln_service*));
  CHECK(int, ln_service_call, (ln_service, void*));
  CHECK(int, ln_service_call_with_timeout, (ln_service, void*, double));
  CHECK(int, ln_service_call_abort, (ln_service));
  CHECK(int, ln_service_callv, (ln_service, struct iovec*, unsigned int, uint8_t*, char**, uint32_t*, uint8_t*));
  CHECK(int, ln_service_callv_with_timeout,
        (ln_service, struct iovec*, unsigned int, uint8_t*, char**, uint32_t*, uint8_t*, double));
  CHECK(int, ln_service_call_async, (ln_service, void*, ln_service_request*));
  CHECK(int, ln_service_callv_async, (ln_service, struct iovec*, unsigned int, uint8_t*, ln_service_request*));
  CHECK(int, ln_service_callv_async_get_response, (ln_service, char**, uint32_t*));
  CHECK(int, ln_service_callv_async_get_response_data, (ln_service, void*));
  CHECK(int, ln_service_request_abort, (ln_service_request));
  CHECK(int, ln_service_request_finished, (ln_service_request, int*));
  CHECK(int, ln_service_request_get_finished_notification_fd, (ln_service_request, int*));
  CHECK(int, ln_service_provider_set_handler, (ln_service, ln_service_handler, void*));
  CHECK(int, ln_service_provider_register, (ln_client, ln_service));
  CHECK(int, ln_service_provider_register_in_group, (ln_client, ln_service, const char*));
  CHECK(int, ln_service_provider_get_fd, (ln_service));
  CHECK(int, ln_service_provider_set_client_fd_handler, (ln_service, ln_service_fd_handler, void*));
  CHECK(int, ln_service_request_set_data, (ln_service_request, void*, const char*));
  CHECK(int, ln_service_request_get_request_data, (ln_service_request, char**, uint64_t*));
  CHECK(int, ln_service_request_respond, (ln_service_request));
  CHECK(int, ln_service_request_respondv, (ln_service_request, struct iovec*, unsigned int));
  CHECK(int, ln_service_request_respond_data, (ln_service_request, void*));
  CHECK(int, ln_service_request_is_aborted, (ln_service_request));
  CHECK(int, ln_wait_and_handle_service_group_requests, (ln_client, const char*, double));
  CHECK(int, ln_handle_service_group_in_thread_pool, (ln_client, const char*, const char*));
  CHECK(int, ln_remove_service_group_from_thread_pool, (ln_client, const char*));
  CHECK(int, ln_unblock_service_group, (ln_client, const char*));
  CHECK(int, ln_set_max_threads, (ln_client, const char*, unsigned int));
  CHECK(int, ln_thread_pool_setschedparam, (ln_client, const char*, int, int, unsigned int));
  CHECK(int, ln_get_service_signature, (ln_client, const char*, char**, char**));
  CHECK(int, ln_get_service_signature_for_service, (ln_client, const char*, char**, char**, char**));
  CHECK(int, ln_get_library_version, (void));
  CHECK(int, ln_register_as_service_logger, (ln_client, const char*, const char*));
  CHECK(int, ln_client_get_logger, (ln_client, ln_logger*, const char*));
  CHECK(int, ln_logger_add_topic, (ln_logger, const char*, unsigned int, unsigned int));
  CHECK(int, ln_logger_add_topic64, (ln_logger, const char*, uint64_t, unsigned int));
  CHECK(int, ln_logger_clear_topics, (ln_logger));
  CHECK(int, ln_logger_set_only_ts, (ln_logger, int));
  CHECK(int, ln_logger_enable, (ln_logger));
  CHECK(int, ln_logger_disable, (ln_logger));
  CHECK(int, ln_logger_download, (ln_logger, ln_logger_data*));
  CHECK(int, ln_logger_direct_download, (ln_logger, ln_logger_data*));
  CHECK(int, ln_logger_manager_save, (ln_logger, const char*, const char*));
  CHECK(int, ln_logger_data_save, (ln_logger_data, const char*));
  CHECK(int, ln_logger_data_load, (ln_logger_data*, const char*));
  CHECK(int, ln_logger_data_deinit, (ln_logger_data*));
  CHECK(int, ln_logger_data_get_info, (ln_logger_data, unsigned int*));
  CHECK(int, ln_logger_data_get_topic, (ln_logger_data, unsigned int, logger_topic**));
  CHECK(int, ln_client_find_services_with_interface, (ln_client, const char*, char**));
  CHECK(int, ln_event_connect,
        (ln_client, ln_event_connection*, const char*, const char*, void*, ln_event_handler, void*));
  CHECK(int, ln_event_connect_flat,
        (ln_client, ln_event_connection*, const char*, const char*, void*, uint32_t, ln_event_handler, void*));
  CHECK(int, ln_event_connection_deinit, (ln_event_connection*));
  CHECK(unsigned int, ln_event_connection_get_id, (ln_event_connection));
  CHECK(int, ln_event_call_set_data, (ln_event_call, const char*, void*));
  CHECK(int, ln_event_call_get_buffer, (ln_event_call, void**, uint32_t*));
  CHECK(int, ln_client_set_float_parameter, (ln_client, const char*, float));
  CHECK(void, ln_get_v16_features, (unsigned int*, unsigned int*));
  CHECK(int, ln_dsa_dss1_sign_message, (const char*, const uint8_t*, unsigned int, uint8_t**, unsigned int*));
  CHECK(int, ln_dsa_dss1_verify_message_signature,
        (const char*, const uint8_t*, unsigned int, const uint8_t*, unsigned int));
  CHECK(int, ln_dsa_dss1_verify_message_signature_memkey,
        (const char*, const uint8_t*, unsigned int, const uint8_t*, unsigned int));
  CHECK(int, ln_dsa_dss1_generate_key_pair, (const char*, const char*));
  /* ln_core extensions */
  CHECK(int, ln_read_with_info, (ln_inport, void*, unsigned int, ln_sample_info*, double));
  CHECK(int, ln_read_borrow, (ln_inport, const void**, unsigned int*, ln_sample_info*, double));
  CHECK(int, ln_read_release, (ln_inport));
  CHECK(int, ln_wait_for_service, (ln_client, const char*, double));
  CHECK(int, ln_service_request_wait, (ln_service_request, double, int*));
  CHECK(int, ln_service_request_respond_error, (ln_service_request, int, const char*));
  CHECK(const char*, ln_service_request_get_error_message, (ln_service_request));
  CHECK(int, ln_set_service_availability_handler, (ln_client, const char*, ln_availability_handler, void*));
  CHECK(int, ln_set_publisher_availability_handler, (ln_client, const char*, ln_availability_handler, void*));
  CHECK(int, ln_list_topics, (ln_client, ln_topic_info**, unsigned int*));
  CHECK(int, ln_list_clients, (ln_client, ln_client_info**, unsigned int*));
  CHECK(int, ln_list_services, (ln_client, ln_service_info**, unsigned int*));
  CHECK(int, ln_get_manager_status, (ln_client, ln_manager_status**));
  CHECK(void, ln_free_list, (void*));
}

/* ---- a typical C program (never called) ---- */
#include "ln/packed.h"
typedef struct LN_PACKED {
  double position;
  uint32_t counter;
} example_packet_t;
typedef struct LN_PACKED {
  struct LN_PACKED example_add_request_t {
    int32_t a;
    int32_t b;
  } req;
  struct LN_PACKED example_add_response_t {
    int32_t sum;
    uint32_t error_message_len;
    char* error_message;
  } resp;
} example_add_t;
#include "ln/endpacked.h"
#define EXAMPLE_ADD_SIGNATURE "int32_t 4 1,int32_t 4 1|int32_t 4 1,uint32_t 4 1,char* 1 1"

static int add_handler(ln_client clnt, ln_service_request req, void* user_data) {
  example_add_t data;
  int ret;
  (void)clnt;
  (void)user_data;
  memset(&data, 0, sizeof data);
  ret = ln_service_request_set_data(req, &data, EXAMPLE_ADD_SIGNATURE);
  if (ret != 0) return ret;
  if (data.req.a < 0) return ln_service_request_respond_error(req, 1, "negative summand");
  data.resp.sum = data.req.a + data.req.b;
  return ln_service_request_respond(req);
}

static void on_event(ln_client clnt, ln_event_call call, void* user_data) {
  void* bytes = NULL;
  uint32_t len = 0;
  (void)clnt;
  (void)user_data;
  (void)ln_event_call_get_buffer(call, &bytes, &len);
}

static void on_fd(ln_client clnt, ln_svc_client_event_t event, int fd, void* user_data) {
  (void)clnt;
  (void)fd;
  (void)user_data;
  (void)(event == LN_NEW_SVC_CLIENT || event == LN_REMOVE_SVC_CLIENT || event == LN_NEW_SVC_FD ||
         event == LN_REMOVE_SVC_FD);
}

static void on_availability(ln_client clnt, const char* name, int available, void* user_data) {
  (void)clnt;
  (void)name;
  (void)available;
  (void)user_data;
}

int c_api_program(int argc, char** argv);
int c_api_program(int argc, char** argv) {
  ln_client clnt = NULL;
  ln_outport out = NULL;
  ln_inport in = NULL;
  ln_multi_waiter waiter = NULL;
  ln_service caller = NULL;
  ln_service provider = NULL;
  ln_service_request pending = NULL;
  ln_event_connection events = NULL;
  ln_logger recorder = NULL;
  ln_sample_info info;
  example_packet_t packet;
  example_add_t add;
  const void* lent = NULL;
  unsigned int lent_size = 0;
  double ts = 0;
  double rtt = 0;
  char* text = NULL;
  int retval = 0;
  int ret = ln_init(&clnt, "c_api_program", argc, argv);
  if (ret != 0) {
    const char* why = ln_format_error(ret);
    (void)why;
    return ret;
  }
  (void)ln_client_get_name(clnt, &text);
  (void)ln_ping(clnt, 1.0, &rtt);

  memset(&packet, 0, sizeof packet);
  (void)ln_publish_with_buffers(clnt, "example.topic", "example/packet", 3, &out);
  packet.position = ln_get_time();
  (void)ln_write(out, &packet, sizeof packet, NULL);
  (void)ln_write(out, &packet, sizeof packet, &ts);

  (void)ln_subscribe(clnt, "example.topic", "example/packet", &in, RATE_AS_PUBLISHED, 0);
  (void)ln_read(in, &packet, (unsigned int)ln_get_message_size(in), &ts, 1);
  (void)ln_read_timeout(in, &packet, sizeof packet, &ts, 0.5);
  (void)ln_read_with_info(in, &packet, sizeof packet, &info, -1);
  if (ln_read_borrow(in, &lent, &lent_size, &info, 0.1) == 1) (void)ln_read_release(in);

  (void)ln_multi_waiter_init(clnt, &waiter);
  (void)ln_multi_waiter_add_port(waiter, in);
  if (ln_multi_waiter_wait(waiter, 1.0) > 0 && ln_multi_waiter_can_read(waiter, in) == 1)
    (void)ln_read(in, &packet, sizeof packet, NULL, 0);
  (void)ln_multi_waiter_deinit(&waiter);

  (void)ln_service_init(clnt, &provider, "example.add", "example/add", EXAMPLE_ADD_SIGNATURE);
  (void)ln_service_provider_set_handler(provider, add_handler, NULL);
  (void)ln_service_provider_set_client_fd_handler(provider, on_fd, NULL);
  (void)ln_service_provider_register_in_group(clnt, provider, "workers");
  (void)ln_handle_service_group_in_thread_pool(clnt, "workers", "pool");
  (void)ln_set_max_threads(clnt, "pool", 2);
  (void)ln_wait_and_handle_service_group_requests(clnt, NULL, 0);

  (void)ln_set_service_availability_handler(clnt, "example.add", on_availability, NULL);
  (void)ln_set_publisher_availability_handler(clnt, "example.topic", on_availability, NULL);
  (void)ln_wait_for_service(clnt, "example.add", 2.0);
  (void)ln_service_init(clnt, &caller, "example.add", "example/add", EXAMPLE_ADD_SIGNATURE);
  memset(&add, 0, sizeof add);
  add.req.a = 1;
  add.req.b = 2;
  ret = ln_service_call_with_timeout(caller, &add, 1.0);
  if (ret > 0) (void)ln_get_error_message(clnt);
  (void)ln_service_call_async(caller, &add, &pending);
  if (ln_service_request_wait(pending, 1.0, &retval) == 1 && retval != 0)
    (void)ln_service_request_get_error_message(pending);
  (void)ln_service_request_finished(pending, &retval);
  (void)ln_service_deinit(&caller);
  (void)ln_service_deinit(&provider);

  (void)ln_event_connect(clnt, &events, "example.event", "sig", NULL, on_event, NULL);
  (void)ln_event_connection_deinit(&events);
  (void)ln_client_get_logger(clnt, &recorder, "recorder");
  (void)ln_logger_add_topic64(recorder, "example.topic", 1000, 1);

  if (ln_get_message_definition(clnt, "example/packet", &text, &lent_size) == 0) free(text);
  (void)ln_unsubscribe(&in);
  (void)ln_unpublish(&out);
  ln_sleep_seconds(0.001);
  (void)ln_get_monotonic_time();
  return ln_deinit(&clnt);
}
