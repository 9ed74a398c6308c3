#include "client/service_logging.hpp"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <sys/syscall.h>
#include <sys/un.h>
#include <unistd.h>

#include <chrono>
#include <cstddef>
#include <cstring>

#include "client/c_api.hpp"
#include "client/client.hpp"
#include "client/failure.hpp"
#include "client/services_glue.hpp"
#include "protocol/methods.hpp"

namespace ln::clientlib {
namespace {

namespace method = protocol::method;
using protocol::Message;

constexpr std::string_view kLogInterface = "ln/log_service";
constexpr std::string_view kLogSignature =
    "uint32_t 4 1,char* 1 1,uint32_t 4 1,char* 1 1,uint32_t 4 1,char* 1 1,uint8_t 1 1,uint8_t 1 1,double 8 1,"
    "double 8 1,double 8 1,uint32_t 4 1,char* 1 1,uint32_t 4 1,uint32_t 4 1,uint64_t 8 1,uint32_t 4 1,uint8_t* 1 1"
    "|uint32_t 4 1,char* 1 1";
// A logger that takes longer than this for one item loses it (and the next
// ones wait meanwhile, up to kMaxQueuedItems).
constexpr double kSendTimeout = 5.0;
constexpr std::uint8_t kDataHasRequestHeader = 2;  // flags bit 1

// LN's flat form, little endian (as the C structs travel on x86).
class Flat {
 public:
  Flat& u8(std::uint8_t v) { return raw(&v, 1); }
  Flat& u16(std::uint16_t v) { return little(v, 2); }
  Flat& u32(std::uint32_t v) { return little(v, 4); }
  Flat& u64(std::uint64_t v) { return little(v, 8); }
  Flat& f64(double v) {
    std::uint64_t bits;
    std::memcpy(&bits, &v, 8);
    return little(bits, 8);
  }
  Flat& text(std::string_view v) {
    u32(static_cast<std::uint32_t>(v.size()));
    out_ += v;
    return *this;
  }
  std::string& str() { return out_; }

 private:
  Flat& little(std::uint64_t v, int bytes) {
    for (int i = 0; i < bytes; ++i) out_ += static_cast<char>((v >> (8 * i)) & 0xff);
    return *this;
  }
  Flat& raw(const void* p, std::size_t n) {
    out_.append(static_cast<const char*>(p), n);
    return *this;
  }
  std::string out_;
};

// The provider's end of a call's connection: its abstract Unix socket name
// (as LN 2.9 shows it, without the leading NUL) or "IP:PORT".
std::string provider_address(int fd, bool we_are_the_provider) {
  sockaddr_storage address{};
  socklen_t size = sizeof address;
  auto* raw = reinterpret_cast<sockaddr*>(&address);
  if (fd < 0 || (we_are_the_provider ? ::getsockname(fd, raw, &size) : ::getpeername(fd, raw, &size)) != 0) return "";
  if (address.ss_family == AF_UNIX) {
    const auto* unix_address = reinterpret_cast<const sockaddr_un*>(&address);
    const std::size_t length = size > offsetof(sockaddr_un, sun_path) ? size - offsetof(sockaddr_un, sun_path) : 0;
    if (length > 0 && unix_address->sun_path[0] == '\0') return std::string(unix_address->sun_path + 1, length - 1);
    return std::string(unix_address->sun_path, ::strnlen(unix_address->sun_path, length));
  }
  if (address.ss_family == AF_INET) {
    const auto* inet = reinterpret_cast<const sockaddr_in*>(&address);
    char ip[INET_ADDRSTRLEN] = "";
    ::inet_ntop(AF_INET, &inet->sin_addr, ip, sizeof ip);
    return std::string(ip) + ":" + std::to_string(ntohs(inet->sin_port));
  }
  return "";
}

// The request or response as LN 2.9 puts it on the wire.
std::string ln29_wire_form(const services::CallLog::Item& item) {
  Flat data;
  if (!item.response) {
    data.u32(static_cast<std::uint32_t>(14 + item.flat.size())).u16(LN_LIBRARY_VERSION);
    data.u32(item.caller_id).u32(item.request_id);
  } else {
    data.u32(static_cast<std::uint32_t>(8 + item.flat.size())).u32(static_cast<std::uint32_t>(item.result));
  }
  data.str() += item.flat;
  return std::move(data.str());
}

}  // namespace

ServiceLogging::ServiceLogging(Client& client, ServicesGlue& glue) : client_(client), glue_(glue) {
  client_id_.store(static_cast<std::uint32_t>(client.client_id()));
}

ServiceLogging::~ServiceLogging() { stop(); }

void ServiceLogging::start() {
  std::weak_ptr<ServicesGlue> glue = glue_.weak_from_this();
  client_.add_notification_handler(std::string(method::add_service_logger), [glue](const Message& message) {
    if (auto alive = glue.lock())
      alive->logging().add_logger(message.get_string_or("service", ""), message.get_string_or("logger_service", ""));
  });
  client_.add_notification_handler(std::string(method::del_service_logger), [glue](const Message& message) {
    if (auto alive = glue.lock()) alive->logging().remove_logger(message.get_string_or("logger_service", ""));
  });
  client_.add_reconnect_handler([glue] {
    auto alive = glue.lock();
    if (!alive) return;
    ServiceLogging& self = alive->logging();
    std::map<std::string, std::string> own;
    {
      std::lock_guard<std::mutex> lock(self.mutex_);
      self.client_id_.store(static_cast<std::uint32_t>(self.client_.client_id()));
      self.loggers_.clear();  // the manager tells again what is logged
      self.update_enabled_locked();
      own = self.own_loggers_;
    }
    // After the glue's own re-registrations, which come first on the connection.
    for (const auto& [logger, patterns] : own) {
      Message request = self.client_.new_request(method::register_as_service_logger);
      request.set("logger_service", logger).set("patterns", patterns);
      self.client_.manager().send_request(std::move(request), [](Reply&) {});
    }
  });
  sender_ = std::thread([this] { send_main(); });
}

void ServiceLogging::stop() {
  std::unique_lock<std::mutex> lock(mutex_);
  stopping_ = true;
  changed_.notify_all();
  while (sending_ != nullptr) {
    sending_->abort();
    changed_.wait_for(lock, std::chrono::milliseconds(10));
  }
  lock.unlock();
  if (sender_.joinable()) sender_.join();
}

void ServiceLogging::register_logger(const std::string& logger_service, const std::string& patterns) {
  if (!glue_.provides(logger_service))
    throw Failure(LNE_SVC_NOT_REGISTERED,
                  "can not make '" + logger_service + "' a service logger: this client does not provide it");
  Message request = client_.new_request(method::register_as_service_logger);
  request.set("logger_service", logger_service).set("patterns", patterns);
  client_.request(std::move(request));
  std::lock_guard<std::mutex> lock(mutex_);
  own_loggers_[logger_service] = patterns;
}

void ServiceLogging::set_loggers(const std::string& service, const std::string& interface,
                                 const std::vector<std::string>& loggers) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (!interface.empty()) interfaces_[service] = interface;
  if (loggers.empty())
    loggers_.erase(service);
  else
    loggers_[service] = std::set<std::string>(loggers.begin(), loggers.end());
  update_enabled_locked();
}

void ServiceLogging::add_logger(const std::string& service, const std::string& logger) {
  std::lock_guard<std::mutex> lock(mutex_);
  loggers_[service].insert(logger);
  update_enabled_locked();
}

void ServiceLogging::remove_logger(const std::string& logger) {
  std::lock_guard<std::mutex> lock(mutex_);
  for (auto it = loggers_.begin(); it != loggers_.end();) {
    it->second.erase(logger);
    it = it->second.empty() ? loggers_.erase(it) : std::next(it);
  }
  update_enabled_locked();
}

void ServiceLogging::update_enabled_locked() { enabled_.store(!loggers_.empty(), std::memory_order_relaxed); }

void ServiceLogging::record(const Item& item) {
  std::vector<std::string> loggers;
  std::string interface(item.interface);
  {
    std::lock_guard<std::mutex> lock(mutex_);
    const auto it = loggers_.find(std::string(item.service));
    if (it == loggers_.end() || stopping_) return;
    loggers.assign(it->second.begin(), it->second.end());
    if (interface.empty()) {
      const auto known = interfaces_.find(std::string(item.service));
      if (known != interfaces_.end()) interface = known->second;
    }
  }
  Flat request;
  request.text(client_.name()).text(item.service).text(interface);
  request.u8(item.response ? 1 : 0).u8(item.response ? 0 : kDataHasRequestHeader);
  request.f64(item.completion_time).f64(item.transfer_time).f64(item.request_time);
  request.text(provider_address(item.fd, item.response));
  request.u32(item.caller_id).u32(item.request_id).u64(static_cast<std::uint64_t>(::syscall(SYS_gettid)));
  request.text(ln29_wire_form(item));
  std::lock_guard<std::mutex> lock(mutex_);
  for (const std::string& logger : loggers) {
    if (queue_.size() >= kMaxQueuedItems) {
      queue_.pop_front();
      if (++dropped_ % 1000 == 1 && client_.debugging())
        client_.debug("service logging: %llu log items dropped so far (the loggers are too slow)",
                      static_cast<unsigned long long>(dropped_));
    }
    queue_.push_back({logger, request.str()});
  }
  changed_.notify_all();
}

void ServiceLogging::send_main() {
  std::shared_ptr<const services::ServiceSignature> signature;
  if (!services::ServiceSignature::compile_shared(kLogSignature, signature).ok()) return;
  std::map<std::string, std::unique_ptr<services::ServiceCaller>> callers;
  std::unique_lock<std::mutex> lock(mutex_);
  for (;;) {
    changed_.wait(lock, [this] { return stopping_ || !queue_.empty(); });
    if (stopping_) return;
    Queued item = std::move(queue_.front());
    queue_.pop_front();
    std::unique_ptr<services::ServiceCaller>& caller = callers[item.logger];
    if (!caller)
      caller = std::make_unique<services::ServiceCaller>(
          signature, glue_.connector(item.logger, std::string(kLogInterface), signature->text()), glue_.reactor(),
          glue_.limits(), glue_.wait_policy(), item.logger);
    sending_ = caller.get();
    lock.unlock();
    const int ret = caller->call_flat(item.request, kSendTimeout);
    if (ret != 0 && client_.debugging())
      client_.debug("service logging: sending to '%s' failed: %s", item.logger.c_str(), caller->last_error().c_str());
    lock.lock();
    sending_ = nullptr;
    changed_.notify_all();
    if (ret == -LNE_NO_PROVIDER_FOUND) callers.erase(item.logger);  // gone: do not keep its connection
  }
}

}  // namespace ln::clientlib
