// ln.h functions that this library does not implement yet. They exist so
// that every LN 2.9 program links; each fails with -LNE_NOT_YET_IMPLEMENTED
// (NULL / 0 / nothing for the few that return something else). Whoever
// implements one deletes it here.
#include "client/c_api.hpp"

#pragma GCC diagnostic ignored "-Wunused-parameter"

extern "C" {

int ln_needs_provider(ln_client clnt, const char* service_or_topic_name, double timeout) { return -LNE_NOT_YET_IMPLEMENTED; }
int ln_service_init(ln_client clnt, ln_service* svc, const char* service_name, const char* service_interface, const char* signature) { return -LNE_NOT_YET_IMPLEMENTED; }
int ln_service_deinit(ln_service* svc) { return -LNE_NOT_YET_IMPLEMENTED; }
int ln_service_call(ln_service svc, void* data) { return -LNE_NOT_YET_IMPLEMENTED; }
int ln_service_call_with_timeout(ln_service svc, void* data, double timeout) { return -LNE_NOT_YET_IMPLEMENTED; }
int ln_service_call_abort(ln_service svc) { return -LNE_NOT_YET_IMPLEMENTED; }
int ln_service_callv(ln_service svc, struct iovec* iov, unsigned int iov_len, uint8_t* iov_element_lens, char** response_buffer, uint32_t* response_len, uint8_t* need_swap) { return -LNE_NOT_YET_IMPLEMENTED; }
int ln_service_callv_with_timeout(ln_service svc, struct iovec* iov, unsigned int iov_len, uint8_t* iov_element_lens, char** response_buffer, uint32_t* response_len, uint8_t* need_swap, double timeout) { return -LNE_NOT_YET_IMPLEMENTED; }
int ln_service_call_async(ln_service svc, void* data, ln_service_request* req) { return -LNE_NOT_YET_IMPLEMENTED; }
int ln_service_callv_async(ln_service svc, struct iovec* iov, unsigned int iov_len, uint8_t* iov_element_lens, ln_service_request* req) { return -LNE_NOT_YET_IMPLEMENTED; }
int ln_service_callv_async_get_response(ln_service svc, char** response_buffer, uint32_t* response_len) { return -LNE_NOT_YET_IMPLEMENTED; }
int ln_service_callv_async_get_response_data(ln_service svc, void* data) { return -LNE_NOT_YET_IMPLEMENTED; }
int ln_service_request_abort(ln_service_request req) { return -LNE_NOT_YET_IMPLEMENTED; }
int ln_service_request_finished(ln_service_request req, int* retval) { return -LNE_NOT_YET_IMPLEMENTED; }
int ln_service_request_get_finished_notification_fd(ln_service_request req, int* fd) { return -LNE_NOT_YET_IMPLEMENTED; }
int ln_service_provider_set_handler(ln_service svc, ln_service_handler handler, void* user_data) { return -LNE_NOT_YET_IMPLEMENTED; }
int ln_service_provider_register(ln_client clnt, ln_service svc) { return -LNE_NOT_YET_IMPLEMENTED; }
int ln_service_provider_register_in_group(ln_client clnt, ln_service svc, const char* group_name) { return -LNE_NOT_YET_IMPLEMENTED; }
int ln_service_provider_get_fd(ln_service svc) { return -LNE_NOT_YET_IMPLEMENTED; }
int ln_service_provider_set_client_fd_handler(ln_service svc, ln_service_fd_handler handler, void* user_data) { return -LNE_NOT_YET_IMPLEMENTED; }
int ln_service_request_set_data(ln_service_request req, void* data, const char* signature) { return -LNE_NOT_YET_IMPLEMENTED; }
int ln_service_request_get_request_data(ln_service_request req, char** buffer, uint64_t* buffer_len) { return -LNE_NOT_YET_IMPLEMENTED; }
int ln_service_request_respond(ln_service_request req) { return -LNE_NOT_YET_IMPLEMENTED; }
int ln_service_request_respondv(ln_service_request req, struct iovec* iov, unsigned int iov_len) { return -LNE_NOT_YET_IMPLEMENTED; }
int ln_service_request_respond_data(ln_service_request req, void* data) { return -LNE_NOT_YET_IMPLEMENTED; }
int ln_service_request_is_aborted(ln_service_request req) { return -LNE_NOT_YET_IMPLEMENTED; }
int ln_wait_and_handle_service_group_requests(ln_client clnt, const char* group_name, double timeout) { return -LNE_NOT_YET_IMPLEMENTED; }
int ln_handle_service_group_in_thread_pool(ln_client clnt, const char* group_name, const char* pool_name) { return -LNE_NOT_YET_IMPLEMENTED; }
int ln_remove_service_group_from_thread_pool(ln_client clnt_, const char* group_name) { return -LNE_NOT_YET_IMPLEMENTED; }
int ln_unblock_service_group(ln_client clnt_, const char* group_name) { return -LNE_NOT_YET_IMPLEMENTED; }
int ln_set_max_threads(ln_client clnt, const char* pool_name, unsigned int n_threads) { return -LNE_NOT_YET_IMPLEMENTED; }
int ln_thread_pool_setschedparam(ln_client clnt, const char* pool_name, int policy, int priority, unsigned int affinity_mask) { return -LNE_NOT_YET_IMPLEMENTED; }
int ln_get_service_signature(ln_client clnt, const char* service_interface, char** definition, char** signature) { return -LNE_NOT_YET_IMPLEMENTED; }
int ln_get_service_signature_for_service(ln_client clnt, const char* service_name, char** service_interface, char** definition, char** signature) { return -LNE_NOT_YET_IMPLEMENTED; }
int ln_client_find_services_with_interface(ln_client clnt, const char* interface_name, char** services) { return -LNE_NOT_YET_IMPLEMENTED; }
int ln_register_as_service_logger(ln_client clnt, const char* logger_service_name, const char* service_name_patterns_to_log) { return -LNE_NOT_YET_IMPLEMENTED; }
int ln_client_get_logger(ln_client clnt, ln_logger* logger, const char* logger_name) { return -LNE_NOT_YET_IMPLEMENTED; }
int ln_logger_add_topic(ln_logger logger, const char* topic_name, unsigned int log_size, unsigned int divisor) { return -LNE_NOT_YET_IMPLEMENTED; }
int ln_logger_add_topic64(ln_logger logger, const char* topic_name, uint64_t log_size, unsigned int divisor) { return -LNE_NOT_YET_IMPLEMENTED; }
int ln_logger_clear_topics(ln_logger logger) { return -LNE_NOT_YET_IMPLEMENTED; }
int ln_logger_set_only_ts(ln_logger logger, int only_ts) { return -LNE_NOT_YET_IMPLEMENTED; }
int ln_logger_enable(ln_logger logger) { return -LNE_NOT_YET_IMPLEMENTED; }
int ln_logger_disable(ln_logger logger) { return -LNE_NOT_YET_IMPLEMENTED; }
int ln_logger_download(ln_logger logger, ln_logger_data* logger_data) { return -LNE_NOT_YET_IMPLEMENTED; }
int ln_logger_direct_download(ln_logger logger, ln_logger_data* logger_data) { return -LNE_NOT_YET_IMPLEMENTED; }
int ln_logger_manager_save(ln_logger logger, const char* filename, const char* format) { return -LNE_NOT_YET_IMPLEMENTED; }
int ln_logger_data_save(ln_logger_data logger_data, const char* filename) { return -LNE_NOT_YET_IMPLEMENTED; }
int ln_logger_data_load(ln_logger_data* logger_data, const char* filename) { return -LNE_NOT_YET_IMPLEMENTED; }
int ln_logger_data_deinit(ln_logger_data* logger_data) { return -LNE_NOT_YET_IMPLEMENTED; }
int ln_logger_data_get_info(ln_logger_data logger_data, unsigned int* n_topics) { return -LNE_NOT_YET_IMPLEMENTED; }
int ln_logger_data_get_topic(ln_logger_data logger_data, unsigned int topic_id, logger_topic** topic) { return -LNE_NOT_YET_IMPLEMENTED; }
int ln_event_connect(ln_client clnt, ln_event_connection* conn, const char* event_name, const char* connect_signature, void* connect_data, ln_event_handler handler, void* user_data) { return -LNE_NOT_YET_IMPLEMENTED; }
int ln_event_connect_flat(ln_client clnt, ln_event_connection* conn, const char* event_name, const char* connect_signature, void* connect_data_flat, uint32_t connect_data_flat_len, ln_event_handler handler, void* user_data) { return -LNE_NOT_YET_IMPLEMENTED; }
int ln_event_connection_deinit(ln_event_connection* conn) { return -LNE_NOT_YET_IMPLEMENTED; }
unsigned int ln_event_connection_get_id(ln_event_connection conn) { return 0; }
int ln_event_call_set_data(ln_event_call call, const char* call_signature, void* call_data) { return -LNE_NOT_YET_IMPLEMENTED; }
int ln_event_call_get_buffer(ln_event_call call, void** ptr, uint32_t* len) { return -LNE_NOT_YET_IMPLEMENTED; }
int ln_client_set_float_parameter(ln_client clnt, const char* name, float value) { return -LNE_NOT_YET_IMPLEMENTED; }
void ln_get_v16_features(unsigned int* is_with_sys_futex, unsigned int* is_glibc_atleast_2_25) {}
int ln_dsa_dss1_sign_message(const char* pem_private_key_filename, const uint8_t* message, unsigned int message_len, uint8_t** signature_out, unsigned int* signature_out_len) { return -LNE_NOT_YET_IMPLEMENTED; }
int ln_dsa_dss1_verify_message_signature(const char* openssh_public_key_filename, const uint8_t* message, unsigned int message_len, const uint8_t* signature, unsigned int signature_len) { return -LNE_NOT_YET_IMPLEMENTED; }
int ln_dsa_dss1_verify_message_signature_memkey(const char* openssh_public_key_contents, const uint8_t* message, unsigned int message_len, const uint8_t* signature, unsigned int signature_len) { return -LNE_NOT_YET_IMPLEMENTED; }
int ln_dsa_dss1_generate_key_pair(const char* pem_private_key_filename, const char* openssh_public_key_filename) { return -LNE_NOT_YET_IMPLEMENTED; }
int create_shm_target(shm_target_t*, const char* name, unsigned int element_size, unsigned int n_elements, unsigned int version) { return -LNE_NOT_YET_IMPLEMENTED; }
int destroy_shm_target(shm_target_t*) { return -LNE_NOT_YET_IMPLEMENTED; }
int open_shm_target(shm_target_t*, const char* name) { return -LNE_NOT_YET_IMPLEMENTED; }
int close_shm_target(shm_target_t*) { return -LNE_NOT_YET_IMPLEMENTED; }
int write_to_shm_target(shm_target_t, double ts, void* data, unsigned int len) { return -LNE_NOT_YET_IMPLEMENTED; }
int get_next_buffer_from_shm_target(shm_target_t, void** buffer) { return -LNE_NOT_YET_IMPLEMENTED; }
int create_shm_source(shm_source_t*, const char* name, unsigned int element_size, unsigned int n_elements, unsigned int version) { return -LNE_NOT_YET_IMPLEMENTED; }
int destroy_shm_source(shm_source_t*) { return -LNE_NOT_YET_IMPLEMENTED; }
int open_shm_source(shm_source_t*, const char* name) { return -LNE_NOT_YET_IMPLEMENTED; }
int shm_source_get_last_counter(shm_source_t* source_, uint32_t* counter) { return -LNE_NOT_YET_IMPLEMENTED; }
int close_shm_source(shm_source_t*) { return -LNE_NOT_YET_IMPLEMENTED; }
int read_from_shm_source(shm_source_t, double* ts, uint32_t* packet_counter, void* data, unsigned int len, int blocking) { return -LNE_NOT_YET_IMPLEMENTED; }
int read_from_shm_source_timeout(shm_source_t, double* ts, uint32_t* packet_counter, void* data, unsigned int len, double timeout) { return -LNE_NOT_YET_IMPLEMENTED; }
int read_last_from_shm_source(shm_source_t, double* ts, uint32_t* packet_counter, void* data, unsigned int len) { return -LNE_NOT_YET_IMPLEMENTED; }
int block_only_on_shm_source(shm_source_t source_, uint32_t* packet_counter, double timeout) { return -LNE_NOT_YET_IMPLEMENTED; }
int unblock_shm_source(shm_source_t source_) { return -LNE_NOT_YET_IMPLEMENTED; }
int ln_wait_for_service(ln_client clnt, const char* service_name, double timeout) { return -LNE_NOT_YET_IMPLEMENTED; }
int ln_service_request_wait(ln_service_request req, double timeout, int* retval) { return -LNE_NOT_YET_IMPLEMENTED; }
int ln_service_request_respond_error(ln_service_request req, int error, const char* message) { return -LNE_NOT_YET_IMPLEMENTED; }
const char* ln_service_request_get_error_message(ln_service_request req) { return nullptr; }
int ln_set_service_availability_handler(ln_client clnt, const char* service_name, ln_availability_handler handler, void* user_data) { return -LNE_NOT_YET_IMPLEMENTED; }
int ln_set_publisher_availability_handler(ln_client clnt, const char* topic_name, ln_availability_handler handler, void* user_data) { return -LNE_NOT_YET_IMPLEMENTED; }

}  // extern "C"
