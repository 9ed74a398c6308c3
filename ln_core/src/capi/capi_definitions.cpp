// ln.h: message-definition queries.
#include <utility>

#include "capi/capi_support.hpp"
#include "client/definitions.hpp"
#include "protocol/methods.hpp"

using ln::capi::client_from;
using ln::capi::guarded;
using ln::capi::malloc_copy;
using ln::capi::require;
using ln::clientlib::Client;
using ln::clientlib::FetchedDefinition;

namespace {

// Fills the optional outputs of the ln_get_message_definition* family. All
// strings are allocated before any is handed out, so a failure leaks nothing.
int hand_out(const FetchedDefinition& fetched, char** md_name, char** md, unsigned int* size, char** hash,
             char** flat) {
  struct Owned {
    char* text = nullptr;
    ~Owned() { std::free(text); }
  } name_copy, md_copy, hash_copy, flat_copy;
  if (md_name != nullptr) name_copy.text = malloc_copy(fetched.name());
  if (md != nullptr) md_copy.text = malloc_copy(fetched.text());
  if (hash != nullptr) hash_copy.text = malloc_copy(fetched.hash());
  if (flat != nullptr) flat_copy.text = malloc_copy(fetched.flat());
  if (size != nullptr) *size = static_cast<unsigned int>(fetched.packet_size());
  if (md_name != nullptr) *md_name = std::exchange(name_copy.text, nullptr);
  if (md != nullptr) *md = std::exchange(md_copy.text, nullptr);
  if (hash != nullptr) *hash = std::exchange(hash_copy.text, nullptr);
  if (flat != nullptr) *flat = std::exchange(flat_copy.text, nullptr);
  return 0;
}

int for_topic(ln_client clnt, const char* topic_name, char** md_name, char** md, unsigned int* size, char** hash) {
  Client* client = client_from(clnt);
  if (client == nullptr) return -LNE_CLIENT_NOT_INITIALIZED;
  return guarded(client, [&] {
    require(topic_name != nullptr, "topic_name");
    return hand_out(FetchedDefinition::for_topic(*client, topic_name), md_name, md, size, hash, nullptr);
  });
}

int by_name(ln_client clnt, const char* name, char** md, unsigned int* size, char** hash, char** flat) {
  Client* client = client_from(clnt);
  if (client == nullptr) return -LNE_CLIENT_NOT_INITIALIZED;
  return guarded(client, [&] {
    require(name != nullptr, "message_definition_name");
    return hand_out(FetchedDefinition::by_name(*client, name), nullptr, md, size, hash, flat);
  });
}

}  // namespace

extern "C" {

int ln_get_message_definition_for_topic(ln_client clnt, const char* topic_name, char** message_definition_name,
                                        char** message_definition, unsigned int* message_size) {
  return for_topic(clnt, topic_name, message_definition_name, message_definition, message_size, nullptr);
}

int ln_get_message_definition_for_topic_v17(ln_client clnt, const char* topic_name, char** message_definition_name,
                                            char** message_definition, unsigned int* message_size, char** hash) {
  return for_topic(clnt, topic_name, message_definition_name, message_definition, message_size, hash);
}

int ln_get_message_definition(ln_client clnt, const char* message_definition_name, char** message_definition,
                              unsigned int* message_size) {
  return by_name(clnt, message_definition_name, message_definition, message_size, nullptr, nullptr);
}

int ln_get_message_definition_v17(ln_client clnt, const char* message_definition_name, char** message_definition,
                                  unsigned int* message_size, char** hash) {
  return by_name(clnt, message_definition_name, message_definition, message_size, hash, nullptr);
}

int ln_get_message_definition_v21(ln_client clnt, const char* message_definition_name, char** message_definition,
                                  unsigned int* message_size, char** hash, char** flat_message_definition) {
  return by_name(clnt, message_definition_name, message_definition, message_size, hash, flat_message_definition);
}

int ln_describe_message_definition(ln_client clnt, const char* message_definition_name, char** message_definition) {
  Client* client = client_from(clnt);
  if (client == nullptr) return -LNE_CLIENT_NOT_INITIALIZED;
  return guarded(client, [&] {
    require(message_definition_name != nullptr, "message_definition_name");
    require(message_definition != nullptr, "message_definition");
    *message_definition = malloc_copy(FetchedDefinition::by_name(*client, message_definition_name).describe());
    return 0;
  });
}

int ln_locate_member_in_message_definition(ln_client clnt, const char* message_definition_name, const char* member,
                                           unsigned int* member_offset, unsigned int* member_byte_len) {
  Client* client = client_from(clnt);
  if (client == nullptr) return -LNE_CLIENT_NOT_INITIALIZED;
  return guarded(client, [&] {
    require(message_definition_name != nullptr, "message_definition_name");
    require(member != nullptr, "member");
    const FetchedDefinition fetched = FetchedDefinition::by_name(*client, message_definition_name);
    ln::md::MemberLocation location;
    try {
      location = ln::md::locate_member(fetched.definition(), member);
    } catch (const ln::md::Error& error) {
      throw ln::clientlib::Failure(LNE_INVALID_PARAMETER, error.message());
    }
    if (member_offset != nullptr) *member_offset = static_cast<unsigned int>(location.offset);
    if (member_byte_len != nullptr) *member_byte_len = static_cast<unsigned int>(location.size);
    return 0;
  });
}

int ln_put_message_definition(ln_client clnt, const char* message_definition_name, const char* message_definition,
                              char** real_message_definition_name) {
  Client* client = client_from(clnt);
  if (client == nullptr) return -LNE_CLIENT_NOT_INITIALIZED;
  return guarded(client, [&] {
    require(message_definition_name != nullptr, "message_definition_name");
    require(message_definition != nullptr, "message_definition");
    ln::protocol::Message request = client->new_request(ln::protocol::method::put_message_definition);
    request.set("name", message_definition_name).set("text", message_definition);
    const ln::protocol::Message answer = client->request(std::move(request));
    if (real_message_definition_name != nullptr)
      *real_message_definition_name = malloc_copy(answer.get_string_or("name", message_definition_name));
    return 0;
  });
}

}  // extern "C"
