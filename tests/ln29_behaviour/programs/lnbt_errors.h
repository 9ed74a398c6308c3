// LN error names for the LN 2.9 behaviour programs: every LNE_* code of
// LN 2.9's ln.h (the same values in ln_core's), so the programs print names
// that compare across both systems.
#pragma once

#include <ln/ln.h>

#include <cstdio>
#include <string>

namespace lnbt {

struct ErrorName {
  int code;
  const char* name;
};

#define LNBT_E(x) \
  { x, #x }
inline const ErrorName error_names[] = {
    LNBT_E(LNE_CHECK_ERRNO),
    LNBT_E(LNE_NO_MEM),
    LNBT_E(LNE_NO_MANAGER_ADDRESS),
    LNBT_E(LNE_INVALID_MANAGER_ADDRESS),
    LNBT_E(LNE_INVALID_HOSTNAME),
    LNBT_E(LNE_UNKNOWN_HOSTNAME),
    LNBT_E(LNE_HOST_WRONG_NET),
    LNBT_E(LNE_GOT_INVALID_RESPONSE),
    LNBT_E(LNE_REGISTER_DENIED),
    LNBT_E(LNE_CLIENT_NOT_INITIALIZED),
    LNBT_E(LNE_REQUEST_FAILED),
    LNBT_E(LNE_FIELD_NOT_IN_HEADER),
    LNBT_E(LNE_STRING_LENGTH_SPEC_MISSING),
    LNBT_E(LNE_PORT_NOT_FOUND),
    LNBT_E(LNE_INVALID_PORT_OBJECT),
    LNBT_E(LNE_SHM_IS_TOO_SMALL),
    LNBT_E(LNE_SHM_IS_TOO_BIG),
    LNBT_E(LNE_SHM_DOES_NOT_EXIT),
    LNBT_E(LNE_PACKET_TOO_LARGE),
    LNBT_E(LNE_SHM_READ_ERROR),
    LNBT_E(LNE_LOST_CONNECTION),
    LNBT_E(LNE_REGISTER_FAILED),
    LNBT_E(LNE_SVC_IS_PROVIDER),
    LNBT_E(LNE_SVC_IS_CLIENT),
    LNBT_E(LNE_SVC_RECV_RESP),
    LNBT_E(LNE_SVC_RECV_RESP_MEM),
    LNBT_E(LNE_SVC_ALREADY_REGISTERED),
    LNBT_E(LNE_SVC_NOT_REGISTERED),
    LNBT_E(LNE_SVC_RECV_REQ),
    LNBT_E(LNE_SVC_RECV_REQ_MEM),
    LNBT_E(LNE_SVC_REQ_SET_DATA_WRONG),
    LNBT_E(LNE_SVC_HANDLER_NO_RESP),
    LNBT_E(LNE_INVALID_REQ_FIELD_FORMAT),
    LNBT_E(LNE_USER_DEFINED_ERROR),
    LNBT_E(LNE_SVC_NO_HANDLER),
    LNBT_E(LNE_SVC_HANDLER_EXC),
    LNBT_E(LNE_SVC_REQ_RUNNING),
    LNBT_E(LNE_SVC_REQ_NOT_RUNNING),
    LNBT_E(LNE_SVC_REQ_ABORTED),
    LNBT_E(LNE_NO_PROVIDER_FOUND),
    LNBT_E(LNE_START_PROVIDER_FAILED),
    LNBT_E(LNE_ERROR_GETTING_SHM_FD),
    LNBT_E(LNE_SHM_NAME_TOO_LONG),
    LNBT_E(LNE_NOT_YET_IMPLEMENTED),
    LNBT_E(LNE_NO_LOGGER_TOPICS),
    LNBT_E(LNE_INTERNAL_ERROR),
    LNBT_E(LNE_TOPIC_ID_OUT_OF_RANGE),
    LNBT_E(LNE_LOG_FILE_TOO_NEW),
    LNBT_E(LNE_WRONG_BYTE_ORDER),
    LNBT_E(LNE_INVALID_SHM_MAGIC),
    LNBT_E(LNE_SHM_VERSION_TOO_NEW),
    LNBT_E(LNE_WRONG_SHM_SIZE),
    LNBT_E(LNE_INVALID_SIGNATURE),
    LNBT_E(LNE_INVALID_PARAMETER),
    LNBT_E(LNE_SVC_RESP_LATER),
    LNBT_E(LNE_SVC_GRP_UNKNOWN),
    LNBT_E(LNE_THREADP_INIT),
    LNBT_E(LNE_NOT_ON_THIS_OS),
    LNBT_E(LNE_PORT_UNBLOCKED),
    LNBT_E(LNE_UNKNOWN_PARAMETER),
    LNBT_E(LNE_SVC_HANDLER_MULTI_RESP),
    LNBT_E(LNE_MANAGER_TOO_OLD),
    LNBT_E(LNE_INVALID_DSA_SIGNATURE),
    LNBT_E(LNE_SVC_TIMEOUT),
    LNBT_E(LNE_SVC_GRP_HANDLED_IN_POOL),
    LNBT_E(LNE_CLNT_NAME_IN_USE),
    LNBT_E(LNE_CHECK_ERROR_CODE),
    LNBT_E(LNE_UNKNOWN),
    LNBT_E(LNE_WRONG_MD_HASH),
};
#undef LNBT_E

inline std::string error_name(int code) {
  if (code < 0) code = -code;
  if (code == 0) return "OK";
  for (const ErrorName& e : error_names)
    if (e.code == code) return e.name;
  return "LNE_#" + std::to_string(code);
}

/// How a program ends on an ln::exception: "error NAME" on stdout (compared across the systems),
/// the details on stderr; returns the exit status 3.
template <class Exception>
int report_exception(const char* program, const Exception& e) {
  std::printf("error %s\n", error_name(e.error).c_str());
  std::fprintf(stderr, "%s: %s (error %d, error_code %d)\n", program, e.what(), static_cast<int>(e.error),
               e.error_code);
  std::fflush(stdout);
  return 3;
}

}  // namespace lnbt
