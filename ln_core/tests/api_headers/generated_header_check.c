/* The same generated header, seen from C: only the packed structs and
   macros apply. Compile-only. */
#include <string.h>

#include "api_check_messages.h"

int use_generated_header_from_c(ln_outport port);
int use_generated_header_from_c(ln_outport port) {
  api_check_sample_t sample;
  api_check_add_service_t call;
  api_check_notice_call_t notice;
  memset(&sample, 0, sizeof sample);
  memset(&call, 0, sizeof call);
  memset(&notice, 0, sizeof notice);
  (void)API_CHECK_ADD_SERVICE_SIGNATURE;
  (void)API_CHECK_NOTICE_CALL_SIGNATURE;
  return ln_write(port, &sample, sizeof sample, NULL);
}
