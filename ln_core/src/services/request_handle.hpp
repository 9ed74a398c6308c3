// What an ln_service_request points to. The C API uses one handle type for
// two things: the request a provider's handler is given (services::Request)
// and a caller's asynchronous call (services::AsyncCall). Both derive from
// RequestHandle, so the C layer can check which one it got and fail cleanly
// (instead of misinterpreting memory) when a program passes the wrong one.
#pragma once

namespace ln::services {

class Request;
class AsyncCall;

class RequestHandle {
 public:
  enum class Side { Provider, Caller };
  Side side() const { return side_; }

 protected:
  explicit RequestHandle(Side side) : side_(side) {}
  ~RequestHandle() = default;
  RequestHandle(const RequestHandle&) = default;
  RequestHandle& operator=(const RequestHandle&) = default;

 private:
  Side side_;
};

/// The ln_service_request for a Request or an AsyncCall, and back; the way
/// back yields nullptr for a handle of the other side (or nullptr).
void* to_handle(Request* request);
void* to_handle(AsyncCall* call);
Request* provider_request(void* handle);
AsyncCall* caller_request(void* handle);

}  // namespace ln::services
