// ln.h: introspection (ln_list_topics, ln_list_clients, ln_list_services,
// ln_get_manager_status) and the manager's processes (ln_list_processes,
// ln_control_process, ln_get_process_output). The manager answers with
// tables of parallel string columns (protocol/methods.hpp); each result reaches the caller as one
// malloc()ed block that ln_free_list() releases: the structs, then the
// NULL-terminated name arrays, then the characters.
#include <algorithm>
#include <charconv>
#include <cstdlib>
#include <cstring>
#include <initializer_list>
#include <limits>
#include <map>
#include <string>
#include <string_view>
#include <vector>

#include "capi/capi_support.hpp"
#include "protocol/methods.hpp"

using ln::capi::client_from;
using ln::capi::guarded;
using ln::capi::require;
using ln::clientlib::Client;
using ln::clientlib::Failure;
using ln::protocol::Message;
namespace method = ln::protocol::method;

namespace {

[[noreturn]] void malformed(const std::string& what) {
  throw Failure(LNE_GOT_INVALID_RESPONSE, "malformed introspection answer from the ln_manager: " + what);
}

template <typename Number>
Number parse_number(const std::string& text, const char* what) {
  Number value{};
  const auto result = std::from_chars(text.data(), text.data() + text.size(), value);
  if (result.ec != std::errc() || result.ptr != text.data() + text.size())
    malformed(std::string(what) + " '" + text + "' is not a number");
  return value;
}

/// One introspection table: string columns of equal length, one entry per row.
class Table {
 public:
  Table(const Message& answer, std::initializer_list<const char*> columns) {
    for (const char* column : columns) {
      const auto& entries = answer.get_list(column);
      if (!columns_.empty() && entries.size() != rows_) malformed(std::string("column '") + column + "' is short");
      rows_ = entries.size();
      columns_[column] = &entries;
    }
  }

  std::size_t rows() const { return rows_; }
  const std::string& text(const char* column, std::size_t row) const { return columns_.at(column)->at(row); }
  template <typename Number>
  Number number(const char* column, std::size_t row) const {
    return parse_number<Number>(text(column, row), column);
  }
  /// A comma-joined list of names ("" = none).
  std::vector<std::string> names(const char* column, std::size_t row) const {
    std::vector<std::string> names;
    const std::string& joined = text(column, row);
    for (std::size_t start = 0; start < joined.size();) {
      const std::size_t comma = std::min(joined.find(',', start), joined.size());
      names.push_back(joined.substr(start, comma - start));
      start = comma + 1;
    }
    return names;
  }

 private:
  std::map<std::string, const std::vector<std::string>*, std::less<>> columns_;
  std::size_t rows_ = 0;
};

/// The part of a result block after the structs: name arrays, then the
/// characters. A Block made without memory only measures; one made on the
/// allocated block also writes and hands out pointers into it.
class Block {
 public:
  Block() = default;
  Block(char* start, std::size_t array_slots)
      : next_slot_(reinterpret_cast<const char**>(start)), next_char_(start + array_slots * sizeof(const char*)) {}

  const char* string(const std::string& text) {
    chars_ += text.size() + 1;
    if (next_char_ == nullptr) return nullptr;
    char* copy = next_char_;
    std::memcpy(copy, text.c_str(), text.size() + 1);
    next_char_ += text.size() + 1;
    return copy;
  }

  const char* const* strings(const std::vector<std::string>& texts) {
    slots_ += texts.size() + 1;
    const char** array = next_slot_;
    if (array != nullptr) next_slot_ += texts.size() + 1;
    for (std::size_t i = 0; i < texts.size(); ++i) {
      const char* copy = string(texts[i]);
      if (array != nullptr) array[i] = copy;
    }
    if (array != nullptr) array[texts.size()] = nullptr;
    return array;
  }

  std::size_t array_slots() const { return slots_; }
  std::size_t bytes() const { return slots_ * sizeof(const char*) + chars_; }

 private:
  std::size_t slots_ = 0;
  std::size_t chars_ = 0;
  const char** next_slot_ = nullptr;
  char* next_char_ = nullptr;
};

/// `rows` structs filled by fill(block, row, info), with everything they
/// point to, in one malloc()ed block (never NULL).
template <typename Row, typename Fill>
Row* pack(std::size_t rows, Fill&& fill) {
  static_assert(alignof(Row) >= alignof(const char*), "the name arrays follow the structs");
  Block measure;
  for (std::size_t row = 0; row < rows; ++row) {
    Row scratch{};
    fill(measure, row, scratch);
  }
  void* memory = std::malloc(std::max<std::size_t>(1, rows * sizeof(Row) + measure.bytes()));
  if (memory == nullptr) throw std::bad_alloc();
  Row* out = static_cast<Row*>(memory);
  Block block(reinterpret_cast<char*>(out + rows), measure.array_slots());
  for (std::size_t row = 0; row < rows; ++row) {
    out[row] = Row{};
    fill(block, row, out[row]);
  }
  return out;
}

/// Asks the manager for `list_method` and packs its table with `fill`.
template <typename Row, typename Fill>
int list(ln_client clnt, std::string_view list_method, std::initializer_list<const char*> columns, Row** out,
         unsigned int* count, Fill&& fill) {
  Client* client = client_from(clnt);
  if (client == nullptr) return -LNE_CLIENT_NOT_INITIALIZED;
  return guarded(client, [&] {
    require(out != nullptr, "the result pointer");
    require(count != nullptr, "count");
    const Message answer = client->request(client->new_request(list_method));
    const Table table(answer, columns);
    *out = pack<Row>(table.rows(), [&](Block& block, std::size_t row, Row& info) { fill(table, block, row, info); });
    *count = static_cast<unsigned int>(table.rows());
    return 0;
  });
}

}  // namespace

extern "C" {

int ln_list_topics(ln_client clnt, ln_topic_info** topics, unsigned int* count) {
  return list(clnt, method::list_topics,
              {"names", "definitions", "hashes", "message_sizes", "publishers", "subscribers", "packets", "rates"},
              topics, count, [](const Table& table, Block& block, std::size_t row, ln_topic_info& info) {
                info.name = block.string(table.text("names", row));
                info.message_definition = block.string(table.text("definitions", row));
                info.hash = block.string(table.text("hashes", row));
                info.message_size = table.number<unsigned int>("message_sizes", row);
                info.publisher = block.string(table.text("publishers", row));
                info.subscribers = table.number<unsigned int>("subscribers", row);
                info.packets = table.number<uint64_t>("packets", row);
                info.rate = table.number<double>("rates", row);
              });
}

int ln_list_clients(ln_client clnt, ln_client_info** clients, unsigned int* count) {
  return list(clnt, method::list_clients,
              {"names", "ids", "pids", "hosts", "host_ids", "published", "subscribed", "services"}, clients, count,
              [](const Table& table, Block& block, std::size_t row, ln_client_info& info) {
                info.name = block.string(table.text("names", row));
                info.id = table.number<int64_t>("ids", row);
                info.pid = table.number<int64_t>("pids", row);
                info.host = block.string(table.text("hosts", row));
                info.host_id = block.string(table.text("host_ids", row));
                info.published = block.strings(table.names("published", row));
                info.subscribed = block.strings(table.names("subscribed", row));
                info.services = block.strings(table.names("services", row));
              });
}

int ln_list_services(ln_client clnt, ln_service_info** services, unsigned int* count) {
  return list(clnt, method::list_services, {"names", "interfaces", "signatures", "providers", "groups"}, services,
              count, [](const Table& table, Block& block, std::size_t row, ln_service_info& info) {
                info.name = block.string(table.text("names", row));
                info.interface = block.string(table.text("interfaces", row));
                info.signature = block.string(table.text("signatures", row));
                info.provider = block.string(table.text("providers", row));
                info.group = block.string(table.text("groups", row));
              });
}

int ln_get_manager_status(ln_client clnt, ln_manager_status** status) {
  Client* client = client_from(clnt);
  if (client == nullptr) return -LNE_CLIENT_NOT_INITIALIZED;
  return guarded(client, [&] {
    require(status != nullptr, "status");
    const Message answer = client->request(client->new_request(method::manager_status));
    auto count = [&](const char* field) {
      return static_cast<unsigned int>(answer.get_int(field, 0, std::numeric_limits<unsigned int>::max()));
    };
    *status = pack<ln_manager_status>(1, [&](Block& block, std::size_t, ln_manager_status& info) {
      info.version = block.string(answer.get_string("version"));
      info.pid = answer.get_int("pid");
      info.address = block.string(answer.get_string("address"));
      info.uptime = answer.get_double("uptime");
      info.clients = count("clients");
      info.topics = count("topics");
      info.services = count("services");
      info.message_definition_dirs = block.strings(answer.get_list("message_definition_dirs"));
    });
    return 0;
  });
}

void ln_free_list(void* list) { std::free(list); }

int ln_list_processes(ln_client clnt, ln_process_info** processes, unsigned int* count) {
  return list(clnt, method::process_list,
              {"names", "kinds", "states", "requested", "pids", "uptimes", "restarts", "ready", "last_exits", "errors",
               "commands", "depends_on", "members"},
              processes, count, [](const Table& table, Block& block, std::size_t row, ln_process_info& info) {
                info.name = block.string(table.text("names", row));
                info.kind = block.string(table.text("kinds", row));
                info.state = block.string(table.text("states", row));
                info.requested = block.string(table.text("requested", row));
                info.pid = table.number<int64_t>("pids", row);
                info.uptime = table.number<double>("uptimes", row);
                info.restarts = table.number<unsigned int>("restarts", row);
                info.ready = table.text("ready", row) == "1";
                info.last_exit = block.string(table.text("last_exits", row));
                info.error = block.string(table.text("errors", row));
                info.command = block.string(table.text("commands", row));
                info.depends_on = block.strings(table.names("depends_on", row));
                info.members = block.strings(table.names("members", row));
              });
}

int ln_control_process(ln_client clnt, const char* name, const char* action, const char* alt_command) {
  Client* client = client_from(clnt);
  if (client == nullptr) return -LNE_CLIENT_NOT_INITIALIZED;
  return guarded(client, [&] {
    require(name != nullptr, "name");
    require(action != nullptr, "action");
    auto request = client->new_request(method::process_control);
    request.set("name", name).set("action", action);
    if (alt_command != nullptr && alt_command[0] != '\0') request.set("alt_command", alt_command);
    client->request(std::move(request));
    return 0;
  });
}

int ln_get_process_output(ln_client clnt, const char* name, uint64_t after, ln_process_output** output) {
  Client* client = client_from(clnt);
  if (client == nullptr) return -LNE_CLIENT_NOT_INITIALIZED;
  return guarded(client, [&] {
    require(name != nullptr, "name");
    require(output != nullptr, "output");
    require(after <= static_cast<uint64_t>(std::numeric_limits<int64_t>::max()), "after");
    auto request = client->new_request(method::process_output);
    request.set("name", name).set("after", static_cast<int64_t>(after));
    const Message answer = client->request(std::move(request));
    auto number = [&](const char* field) {
      return static_cast<uint64_t>(answer.get_int(field, 0, std::numeric_limits<int64_t>::max()));
    };
    *output = pack<ln_process_output>(1, [&](Block& block, std::size_t, ln_process_output& info) {
      info.lines = block.strings(answer.get_list("lines"));
      info.first = number("first");
      info.last = number("last");
      info.dropped = number("dropped");
    });
    return 0;
  });
}

}  // extern "C"
