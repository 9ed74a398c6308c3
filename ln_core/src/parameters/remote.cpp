#include "parameters/remote.hpp"

#include <cstdlib>
#include <cstring>
#include <map>
#include <memory>
#include <mutex>
#include <optional>

#include "client/failure.hpp"
#include "ln_parameter_messages.h"
#include "parameters/diagnostics.hpp"
#include "parameters/literal.hpp"

namespace ln::paramcore {

using clientlib::Failure;

namespace {

constexpr double kQueryTimeout = 10;
// Longer than a provider waits for a block's step (10 s), so its answer arrives.
constexpr double kOverrideTimeout = 15;
constexpr const char* kQueryDict = "query_dict";

// One caller handle; calls on it and reading their response are serialised
// (the response lives in the handle until its next call).
class Caller {
 public:
  Caller(ln_client clnt, const std::string& name, const char* interface, const char* signature) {
    const int ret = ln_service_init(clnt, &svc_, name.c_str(), interface, signature);
    if (ret < 0) throw Failure(-ret, "parameters: " + name + ": " + ln_get_error_message(clnt));
  }
  ~Caller() { ln_service_deinit(&svc_); }
  Caller(const Caller&) = delete;
  Caller& operator=(const Caller&) = delete;

  std::mutex mutex;
  int call(void* data, double timeout) { return ln_service_call_with_timeout(svc_, data, timeout); }

 private:
  ln_service svc_ = nullptr;
};

// What a client knows about the providers it talked to.
struct Provider {
  std::string query_dict_service;  // "ln.parameters.query_dict.<client>"
  std::shared_ptr<Caller> query, query_dict, override;
};

struct Known {
  std::string provider;  // key of RemoteState::providers
  std::string description;
  std::optional<std::pair<ElementType, Shape>> signature;
};

struct RemoteState {
  std::mutex mutex;  // the maps; never held during a call
  std::map<std::string, Provider> providers;
  std::map<std::string, Known> known;
};

std::mutex& states_mutex() {
  static std::mutex mutex;
  return mutex;
}
std::map<ln_client, std::shared_ptr<RemoteState>>& states() {
  static std::map<ln_client, std::shared_ptr<RemoteState>> all;
  return all;
}

std::shared_ptr<RemoteState> state_of(ln_client clnt) {
  std::lock_guard<std::mutex> lock(states_mutex());
  std::shared_ptr<RemoteState>& state = states()[clnt];
  if (!state) state = std::make_shared<RemoteState>();
  return state;
}

// "ln.parameters.query_dict.x" -> "ln.parameters.<kind>.x", as LN 2.9 derives them.
std::string sibling_service(const std::string& query_dict_service, const char* kind) {
  std::string name = query_dict_service;
  const std::size_t at = name.find(kQueryDict);
  if (at != std::string::npos) name.replace(at, std::strlen(kQueryDict), kind);
  return name;
}

std::string provider_label(const std::string& query_dict_service) {
  const std::string prefix = "ln.parameters.query_dict.";
  return query_dict_service.compare(0, prefix.size(), prefix) == 0
             ? "client '" + query_dict_service.substr(prefix.size()) + "'"
             : "'" + query_dict_service + "'";
}

std::string call_error(ln_client clnt, int ret, const std::string& service) {
  const char* detail = ln_get_error_message(clnt);
  return service + ": " + ln_format_error(ret) +
         (detail != nullptr && detail[0] != '\0' ? std::string(": ") + detail : "");
}

// A provider that does not answer in time is there but busy (or handles
// requests only inside update()); asking others would not help.
[[noreturn]] void throw_no_answer(const std::string& provider_key, double timeout) {
  throw Failure(LNE_SVC_TIMEOUT, provider_label(provider_key) + " did not answer within " +
                                     std::to_string(static_cast<int>(timeout)) +
                                     " s (with LN_PARAMETER_SYNC_HANDLING=1 a provider answers only inside update())");
}

std::shared_ptr<Caller> caller(ln_client clnt, RemoteState& state, const std::string& provider_key,
                               std::shared_ptr<Caller> Provider::*which, const char* kind, const char* interface,
                               const char* signature) {
  std::lock_guard<std::mutex> lock(state.mutex);
  Provider& provider = state.providers[provider_key];
  provider.query_dict_service = provider_key;
  std::shared_ptr<Caller>& handle = provider.*which;
  if (!handle) handle = std::make_shared<Caller>(clnt, sibling_service(provider_key, kind), interface, signature);
  return handle;
}

void drop_provider(RemoteState& state, const std::string& provider_key) {
  std::lock_guard<std::mutex> lock(state.mutex);
  state.providers.erase(provider_key);
  for (auto it = state.known.begin(); it != state.known.end();)
    it = it->second.provider == provider_key ? state.known.erase(it) : std::next(it);
}

// The query_dict text of `provider_key` for `pattern`, or nullopt if the
// provider could not be asked.
std::optional<std::string> query_dict(ln_client clnt, RemoteState& state, const std::string& provider_key,
                                      const std::string& pattern, std::string& problem) {
  const std::shared_ptr<Caller> handle = caller(clnt, state, provider_key, &Provider::query_dict, kQueryDict,
                                                "ln/parameters/query_dict", LN_PARAMETERS_QUERY_DICT_SIGNATURE);
  std::lock_guard<std::mutex> lock(handle->mutex);
  ln_parameters_query_dict_t data{};
  data.req.pattern = const_cast<char*>(pattern.c_str());
  data.req.pattern_len = static_cast<std::uint32_t>(pattern.size());
  const int ret = handle->call(&data, kQueryTimeout);
  if (ret != 0) {
    problem = ret == -LNE_SVC_TIMEOUT ? provider_label(provider_key) + " did not answer"
                                      : call_error(clnt, ret, provider_key);
    debug_log(clnt, "asking %s failed: %s", provider_key.c_str(), problem.c_str());
    return std::nullopt;
  }
  return std::string(data.resp.data != nullptr ? data.resp.data : "", data.resp.data_len);
}

// Asks every provider for `name`; remembers and returns the one that has it.
Known discover(ln_client clnt, RemoteState& state, const std::string& name) {
  char* listed = nullptr;
  const int ret = ln_client_find_services_with_interface(clnt, "ln/parameters/query_dict", &listed);
  if (ret < 0) throw Failure(-ret, "looking for parameter providers: " + std::string(ln_get_error_message(clnt)));
  const std::string services = listed != nullptr ? listed : "";
  std::free(listed);
  std::vector<std::pair<std::string, std::string>> found;  // provider, description
  std::vector<std::string> unanswered;
  std::size_t asked = 0;
  for (std::size_t start = 0; start < services.size();) {
    std::size_t end = services.find('\n', start);
    if (end == std::string::npos) end = services.size();
    const std::string service = services.substr(start, end - start);
    start = end + 1;
    if (service.empty()) continue;
    ++asked;
    std::string problem;
    const std::optional<std::string> text = query_dict(clnt, state, service, name, problem);
    if (!text) {
      unanswered.push_back(problem);
      drop_provider(state, service);
      continue;
    }
    Literal dict;
    std::string error;
    if (!parse_literal(*text, dict, error) || dict.kind != Literal::Kind::Dict) {
      debug_log(clnt, "%s answered no dict: %s", service.c_str(), error.c_str());
      continue;
    }
    for (std::size_t i = 0; i + 1 < dict.items.size(); i += 2) {
      if (dict.items[i].kind != Literal::Kind::String || dict.items[i].text != name) continue;
      const Literal* description = dict.items[i + 1].keyword("description");
      found.emplace_back(service,
                         description != nullptr && description->kind == Literal::Kind::String ? description->text : "");
    }
  }
  if (found.empty()) {
    std::string text = "no client provides parameter '" + name + "' (asked " + std::to_string(asked) +
                       " parameter provider" + (asked == 1 ? "" : "s");
    for (const std::string& problem : unanswered) text += "; " + problem;
    throw Failure(unanswered.empty() ? LNE_UNKNOWN_PARAMETER : LNE_SVC_TIMEOUT, text + ")");
  }
  if (found.size() > 1) {
    std::string who;
    for (const auto& f : found) who += (who.empty() ? "" : " and ") + provider_label(f.first);
    throw Failure(LNE_INVALID_PARAMETER, "parameter '" + name + "' is provided by " + who);
  }
  debug_log(clnt, "parameter '%s' is provided by %s", name.c_str(), provider_label(found[0].first).c_str());
  std::lock_guard<std::mutex> lock(state.mutex);
  Known& known = state.known[name];
  known = Known{found[0].first, found[0].second, std::nullopt};
  return known;
}

Known locate(ln_client clnt, RemoteState& state, const std::string& name, bool rediscover) {
  if (!rediscover) {
    std::lock_guard<std::mutex> lock(state.mutex);
    const auto it = state.known.find(name);
    if (it != state.known.end()) return it->second;
  }
  return discover(clnt, state, name);
}

// One binary query of `name` at `provider_key`; nullopt if the provider
// could not be asked or does not have it (any more).
std::optional<RemoteValue> query(ln_client clnt, RemoteState& state, const std::string& provider_key,
                                 const std::string& name, std::string& problem) {
  const std::shared_ptr<Caller> handle = caller(clnt, state, provider_key, &Provider::query, "query",
                                                "ln/parameters/query", LN_PARAMETERS_QUERY_SIGNATURE);
  std::lock_guard<std::mutex> lock(handle->mutex);
  ln_parameters_query_t data{};
  data.req.pattern = const_cast<char*>(name.c_str());
  data.req.pattern_len = static_cast<std::uint32_t>(name.size());
  const int ret = handle->call(&data, kQueryTimeout);
  if (ret == -LNE_SVC_TIMEOUT) throw_no_answer(provider_key, kQueryTimeout);
  if (ret != 0) {
    problem = call_error(clnt, ret, sibling_service(provider_key, "query"));
    return std::nullopt;
  }
  for (std::uint32_t i = 0; i < data.resp.values_len; ++i) {
    const ln_parameters_value_t& v = data.resp.values[i];
    if (std::string(v.name, v.name_len) != name) continue;
    RemoteValue value;
    value.name = name;
    value.data_type.assign(v.data_type, v.data_type_len);
    if (!parse_binary_type_string(value.data_type, value.type, value.shape))
      throw Failure(LNE_GOT_INVALID_RESPONSE, "parameter '" + name + "': unknown data_type '" + value.data_type + "'");
    const std::size_t bytes = value.shape.elements() * element_size(value.type);
    if (v.input_data_len != bytes || v.output_data_len != bytes)
      throw Failure(LNE_GOT_INVALID_RESPONSE, "parameter '" + name + "' (" + value.data_type +
                                                  "): " + std::to_string(v.input_data_len) +
                                                  " bytes of data, expected " + std::to_string(bytes));
    value.input.resize(bytes);
    value.output.resize(bytes);
    // The binary form carries matrices column-major.
    to_row_major(v.input_data, value.input.data(), value.type, value.shape, false);
    to_row_major(v.output_data, value.output.data(), value.type, value.shape, false);
    value.override_enabled = v.override_enabled != 0;
    return value;
  }
  problem = sibling_service(provider_key, "query") + " does not have it (any more)";
  return std::nullopt;
}

// Sends override text; returns the provider's error ("" = done), or
// nullopt if the provider could not be asked.
std::optional<std::string> send_override(ln_client clnt, RemoteState& state, const std::string& provider_key,
                                         const std::string& name, const std::string& text, bool wait_step,
                                         std::string& problem) {
  const std::shared_ptr<Caller> handle =
      caller(clnt, state, provider_key, &Provider::override, "override_dict_single",
             "ln/parameters/override_dict_single", LN_PARAMETERS_OVERRIDE_DICT_SINGLE_SIGNATURE);
  std::lock_guard<std::mutex> lock(handle->mutex);
  ln_parameters_override_dict_single_t data{};
  data.req.parameter_name = const_cast<char*>(name.c_str());
  data.req.parameter_name_len = static_cast<std::uint32_t>(name.size());
  data.req.override_data = const_cast<char*>(text.c_str());
  data.req.override_data_len = static_cast<std::uint32_t>(text.size());
  data.req.wait_step = wait_step ? 1 : 0;
  const int ret = handle->call(&data, kOverrideTimeout);
  if (ret == -LNE_SVC_TIMEOUT) throw_no_answer(provider_key, kOverrideTimeout);
  if (ret != 0) {
    problem = call_error(clnt, ret, sibling_service(provider_key, "override_dict_single"));
    return std::nullopt;
  }
  return std::string(data.resp.error != nullptr ? data.resp.error : "", data.resp.error_len);
}

bool says_unknown(const std::string& provider_error) {
  // ln_core's and LN 2.9's providers' answers for a name they do not have.
  return provider_error.rfind("no parameter '", 0) == 0 ||
         provider_error.find("there is no parameter matching") != std::string::npos;
}

bool kinds_compatible(ElementKind a, ElementKind b) {
  auto integer = [](ElementKind k) { return k == ElementKind::Signed || k == ElementKind::Unsigned; };
  return a == b || (integer(a) && integer(b));
}

const char* kind_name(ElementKind kind) {
  switch (kind) {
    case ElementKind::Floating:
      return "floating";
    case ElementKind::Signed:
      return "signed integer";
    case ElementKind::Unsigned:
      return "unsigned integer";
    case ElementKind::Boolean:
      break;
  }
  return "boolean";
}

std::string shape_text(unsigned rank, const std::uint32_t* dims) {
  if (rank == 0) return "a scalar";
  std::string text = "[";
  for (unsigned i = 0; i < rank; ++i) text += (i != 0 ? ", " : "") + std::to_string(dims[i]);
  return text + "]";
}

// Overrides with `make_text(signature)` at the remembered provider, looking
// the parameter up again once if that provider no longer has it.
template <typename MakeText>
void override_with(ln_client clnt, const std::string& name, int flags, bool needs_signature, MakeText make_text) {
  const std::shared_ptr<RemoteState> state = state_of(clnt);
  bool rediscover = (flags & LN_PARAMETER_REDISCOVER) != 0;
  std::string problem;
  for (int attempt = 0; attempt < 2; ++attempt, rediscover = true) {
    Known known = locate(clnt, *state, name, rediscover);
    if (needs_signature && !known.signature) {
      const std::optional<RemoteValue> value = query(clnt, *state, known.provider, name, problem);
      if (!value) {
        drop_provider(*state, known.provider);
        continue;
      }
      known.signature = std::make_pair(value->type, value->shape);
      std::lock_guard<std::mutex> lock(state->mutex);
      state->known[name].signature = known.signature;
    }
    const std::string text = make_text(known.signature);
    const std::optional<std::string> error =
        send_override(clnt, *state, known.provider, name, text, (flags & LN_PARAMETER_WAIT_STEP) != 0, problem);
    if (!error) {
      drop_provider(*state, known.provider);
      continue;
    }
    if (error->empty()) {
      debug_log(clnt, "parameter '%s' %s", name.c_str(),
                text.empty() ? "override ended" : ("overridden with " + text).c_str());
      return;
    }
    if (says_unknown(*error)) {
      problem = *error;
      drop_provider(*state, known.provider);
      continue;
    }
    throw Failure(LNE_REQUEST_FAILED,
                  provider_label(known.provider) + " refused to override parameter '" + name + "': " + *error);
  }
  throw Failure(LNE_UNKNOWN_PARAMETER, "parameter '" + name + "' is not available: " + problem);
}

}  // namespace

RemoteValue get_parameter(ln_client clnt, const std::string& name, int flags) {
  const std::shared_ptr<RemoteState> state = state_of(clnt);
  bool rediscover = (flags & LN_PARAMETER_REDISCOVER) != 0;
  std::string problem;
  for (int attempt = 0; attempt < 2; ++attempt, rediscover = true) {
    const Known known = locate(clnt, *state, name, rediscover);
    std::optional<RemoteValue> value = query(clnt, *state, known.provider, name, problem);
    if (!value) {
      drop_provider(*state, known.provider);
      continue;
    }
    value->description = known.description;
    std::lock_guard<std::mutex> lock(state->mutex);
    state->known[name].signature = std::make_pair(value->type, value->shape);
    return std::move(*value);
  }
  throw Failure(LNE_UNKNOWN_PARAMETER, "parameter '" + name + "' is not available: " + problem);
}

void override_parameter_text(ln_client clnt, const std::string& name, const std::string& text, int flags) {
  override_with(clnt, name, flags, false, [&](const auto&) { return text; });
}

void override_parameter_data(ln_client clnt, const std::string& name, ElementType type, unsigned n_dims,
                             const std::uint32_t* dims, const void* data, int flags) {
  if (n_dims > 2 || (n_dims > 0 && dims == nullptr))
    throw Failure(LNE_INVALID_PARAMETER, "parameter '" + name + "': a value has 0, 1 or 2 dimensions");
  if (data == nullptr) throw Failure(LNE_INVALID_PARAMETER, "parameter '" + name + "': the data is NULL");
  override_with(clnt, name, flags, true, [&](const std::optional<std::pair<ElementType, Shape>>& signature) {
    const auto& [target, shape] = *signature;
    RemoteValue view;
    view.shape = shape;
    const unsigned rank = view.rank();
    const std::string who = "parameter '" + name + "' (" + binary_type_string(target, shape) + ")";
    bool same_shape = rank == n_dims;
    for (unsigned i = 0; same_shape && i < rank; ++i) same_shape = dims[i] == shape.dims[i];
    if (!same_shape)
      throw Failure(LNE_INVALID_PARAMETER, who + " has shape " + shape_text(rank, shape.dims.data()) +
                                               ", the value has shape " + shape_text(n_dims, dims));
    if ((flags & LN_PARAMETER_STRICT_TYPES) != 0 && !kinds_compatible(element_kind(target), element_kind(type)))
      throw Failure(LNE_INVALID_PARAMETER, who + " has " + kind_name(element_kind(target)) + " values, the value is " +
                                               kind_name(element_kind(type)));
    std::vector<std::uint8_t> converted(shape.elements() * element_size(target));
    const auto* in = static_cast<const std::uint8_t*>(data);
    for (std::size_t i = 0; i < shape.elements(); ++i) {
      const std::string error = store_element(target, load_element(type, in + i * element_size(type)),
                                              converted.data() + i * element_size(target));
      if (!error.empty()) throw Failure(LNE_INVALID_PARAMETER, who + ": " + error);
    }
    return format_value_for_override(target, shape, converted.data());
  });
}

std::string read_value(const RemoteValue& value, bool output, ElementType type, void* data, std::size_t n_elements,
                       bool strict_types) {
  const std::string who = "parameter '" + value.name + "' (" + value.data_type + ")";
  if (n_elements != value.shape.elements())
    return who + " has " + std::to_string(value.shape.elements()) + " elements, not " + std::to_string(n_elements);
  if (strict_types && !kinds_compatible(element_kind(value.type), element_kind(type)))
    return who + " has " + kind_name(element_kind(value.type)) + " values, not " + kind_name(element_kind(type));
  const std::vector<std::uint8_t>& from = output ? value.output : value.input;
  auto* out = static_cast<std::uint8_t*>(data);
  for (std::size_t i = 0; i < n_elements; ++i) {
    const std::string error = store_element(type, load_element(value.type, from.data() + i * element_size(value.type)),
                                            out + i * element_size(type));
    if (!error.empty()) return who + ": " + error;
  }
  return "";
}

void forget_remote_state(ln_client clnt) {
  std::shared_ptr<RemoteState> state;
  {
    std::lock_guard<std::mutex> lock(states_mutex());
    const auto it = states().find(clnt);
    if (it == states().end()) return;
    state = std::move(it->second);
    states().erase(it);
  }
  std::lock_guard<std::mutex> lock(state->mutex);
  state->providers.clear();  // releases the caller handles not in use
}

}  // namespace ln::paramcore
