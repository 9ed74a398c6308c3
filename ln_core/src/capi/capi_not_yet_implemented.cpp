// ln.h functions that this library does not implement yet. They exist so
// that every LN 2.9 program links; each fails with -LNE_NOT_YET_IMPLEMENTED
// (NULL / 0 / nothing for the few that return something else). Whoever
// implements one deletes it here.
#include "client/c_api.hpp"

#pragma GCC diagnostic ignored "-Wunused-parameter"

extern "C" {

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
int ln_client_set_float_parameter(ln_client clnt, const char* name, float value) { return -LNE_NOT_YET_IMPLEMENTED; }

}  // extern "C"
