#include "client/failure.hpp"

#include <cerrno>
#include <cstdio>
#include <cstring>

namespace ln::clientlib {
namespace {

// Index = LNE_* code. The "NAME - text" form is what LN 2.9 prints, so
// programs that log ln_format_error() keep recognisable output; the texts for
// the manager-address errors are LN's own wording (users search for them).
constexpr const char* kTexts[] = {
    nullptr,
    nullptr,  // LNE_CHECK_ERRNO: formatted with the errno
    "LNE_NO_MEM - out of memory",
    "LNE_NO_MANAGER_ADDRESS - no --ln-manager HOST:PORT command line argument and no LN_MANAGER environment var",
    "LNE_INVALID_MANAGER_ADDRESS - specified ln_manager address is not in format HOST_OR_IP:PORT_NUMBER",
    "LNE_INVALID_HOSTNAME - the manager host is neither a host name nor an IP address",
    "LNE_UNKNOWN_HOSTNAME - the manager host name does not resolve",
    "LNE_HOST_WRONG_NET - the manager host has no IPv4 address",
    "LNE_GOT_INVALID_RESPONSE - the ln_manager sent a malformed answer",
    "LNE_REGISTER_DENIED - the ln_manager refused to register this client",
    "LNE_CLIENT_NOT_INITIALIZED - the client handle is not initialised",
    "LNE_REQUEST_FAILED - the ln_manager could not do what was asked - see ln_get_error_message()",
    "LNE_FIELD_NOT_IN_HEADER - a field is missing in a message from the ln_manager",
    "LNE_STRING_LENGTH_SPEC_MISSING - a string format lacks its length",
    "LNE_PORT_NOT_FOUND - no such port",
    "LNE_INVALID_PORT_OBJECT - the handle is not a port of the expected kind",
    "LNE_SHM_IS_TOO_SMALL - the shared-memory segment is too small",
    "LNE_SHM_IS_TOO_BIG - the shared-memory segment is too big",
    "LNE_SHM_DOES_NOT_EXIT - the shared-memory segment does not exist",
    "LNE_PACKET_TOO_LARGE - the packet is larger than the topic's message size",
    "LNE_SHM_READ_ERROR - reading from the shared-memory segment failed",
    "LNE_LOST_CONNECTION - the connection to the ln_manager is lost",
    "LNE_REGISTER_FAILED - registering with the ln_manager failed",
    "LNE_SVC_IS_PROVIDER - this service handle is a provider, not a caller",
    "LNE_SVC_IS_CLIENT - this service handle is a caller, not a provider",
    "LNE_SVC_RECV_RESP - receiving the service response failed",
    "LNE_SVC_RECV_RESP_MEM - no memory for the service response",
    "LNE_SVC_ALREADY_REGISTERED - the service provider is already registered",
    "LNE_SVC_NOT_REGISTERED - the service provider is not registered yet",
    "LNE_SVC_RECV_REQ - receiving the service request failed",
    "LNE_SVC_RECV_REQ_MEM - no memory for the service request",
    "LNE_SVC_REQ_SET_DATA_WRONG - the signature given to ln_service_request_set_data() does not match the service",
    "LNE_SVC_HANDLER_NO_RESP - the service handler returned 0 without calling ln_service_request_respond()",
    "LNE_INVALID_REQ_FIELD_FORMAT - invalid request field format",
    "LNE_USER_DEFINED_ERROR - error code defined by the service provider",
    "LNE_SVC_NO_HANDLER - a service provider needs a handler before it is registered",
    "LNE_SVC_HANDLER_EXC - the service handler threw an exception",
    "LNE_SVC_REQ_RUNNING - a call is already running on this service handle",
    "LNE_SVC_REQ_NOT_RUNNING - no asynchronous call is running",
    "LNE_SVC_REQ_ABORTED - the service call was aborted",
    "LNE_NO_PROVIDER_FOUND - nothing provides this service or topic",
    "LNE_START_PROVIDER_FAILED - starting a provider for this service or topic failed",
    "LNE_ERROR_GETTING_SHM_FD - no file descriptor for the shared-memory segment",
    "LNE_SHM_NAME_TOO_LONG - the shared-memory name is too long",
    "LNE_NOT_YET_IMPLEMENTED - this feature is not implemented yet",
    "LNE_NO_LOGGER_TOPICS - the logger has no topics",
    "LNE_INTERNAL_ERROR - internal error of the LN library",
    "LNE_TOPIC_ID_OUT_OF_RANGE - logger topic index out of range",
    "LNE_LOG_FILE_TOO_NEW - the log file format is unknown or too new",
    "LNE_WRONG_BYTE_ORDER - the data is not in host byte order",
    "LNE_INVALID_SHM_MAGIC - the shared-memory segment has a foreign layout",
    "LNE_SHM_VERSION_TOO_NEW - the shared-memory layout is newer than this library",
    "LNE_WRONG_SHM_SIZE - the shared-memory segment size is inconsistent",
    "LNE_INVALID_SIGNATURE - invalid signature",
    "LNE_INVALID_PARAMETER - invalid parameter",
    "LNE_SVC_RESP_LATER - the service request will be answered later",
    "LNE_SVC_GRP_UNKNOWN - unknown service group",
    "LNE_THREADP_INIT - the thread pool is not available",
    "LNE_NOT_ON_THIS_OS - not available on this operating system",
    "LNE_PORT_UNBLOCKED - the blocking read was ended by ln_unblock()",
    "LNE_UNKNOWN_PARAMETER - unknown parameter",
    "LNE_SVC_HANDLER_MULTI_RESP - the service handler responded more than once",
    "LNE_MANAGER_TOO_OLD - the ln_manager is too old for this request",
    "LNE_INVALID_DSA_SIGNATURE - the DSA signature does not verify",
    "LNE_SVC_TIMEOUT - the service call did not finish in time",
    "LNE_SVC_GRP_HANDLED_IN_POOL - this service group is already handled by a thread pool",
    "LNE_CLNT_NAME_IN_USE - the requested client name is already in use",
    "LNE_CHECK_ERROR_CODE - C++ only: see ln::exception::error_code",
    "unknown error",
    "LNE_WRONG_MD_HASH - the message definition does not have the expected hash",
};
constexpr int kLastCode = static_cast<int>(sizeof(kTexts) / sizeof(kTexts[0])) - 1;

thread_local int remembered_errno = 0;
thread_local char errno_text[160];

}  // namespace

void remember_errno(int sys_errno) noexcept {
  remembered_errno = sys_errno;
  errno = sys_errno;
}

Failure errno_failure(int sys_errno, const std::string& what) {
  remember_errno(sys_errno);
  return Failure(1, what + ": " + std::strerror(sys_errno));
}

const char* error_text(int code) noexcept {
  if (code < 0) code = -code;
  if (code == 1) {
    const int sys_errno = remembered_errno != 0 ? remembered_errno : errno;
    std::snprintf(errno_text, sizeof errno_text, "errno %d - %s", sys_errno, std::strerror(sys_errno));
    return errno_text;
  }
  if (code < 1 || code > kLastCode) return "unknown error";
  return kTexts[code];
}

}  // namespace ln::clientlib
