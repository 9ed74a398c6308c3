#include "client/definitions.hpp"

#include <cstdio>
#include <set>

#include "client/c_api.hpp"
#include "client/client.hpp"
#include "client/failure.hpp"
#include "protocol/methods.hpp"

namespace ln::clientlib {
namespace {

// Type numbers of LN's flattened definitions (those of Simulink's data types).
int flat_type_id(md::Primitive type) {
  switch (type) {
    case md::Primitive::Double:
      return 0;
    case md::Primitive::Float:
      return 1;
    case md::Primitive::Char:
    case md::Primitive::Int8:
      return 2;
    case md::Primitive::UInt8:
      return 3;
    case md::Primitive::Int16:
      return 4;
    case md::Primitive::UInt16:
      return 5;
    case md::Primitive::Int32:
      return 6;
    case md::Primitive::UInt32:
      return 7;
    case md::Primitive::Int64:
      return -1;
    case md::Primitive::UInt64:
      return -2;
  }
  return 0;
}

// One line "type_id size count name" per primitive field; sub-types are
// expanded with "outer_inner" names, array elements of sub-types as
// "outer_inner[i]".
void flatten(const md::Definition& definition, std::vector<std::string>& lines) {
  for (const md::Field& field : definition.fields) {
    if (field.sub != nullptr) {
      std::vector<std::string> inner;
      flatten(*field.sub, inner);
      for (std::uint32_t element = 0; element < field.count; ++element) {
        for (const std::string& line : inner) {
          const auto space = line.rfind(' ');
          std::string inner_name = line.substr(space + 1);
          if (field.count > 1) inner_name += "[" + std::to_string(element) + "]";
          lines.push_back(line.substr(0, space) + " " + field.name + "_" + inner_name);
        }
      }
      continue;
    }
    lines.push_back(std::to_string(flat_type_id(*field.primitive)) + " " +
                    std::to_string(md::size_of(*field.primitive)) + " " + std::to_string(field.count) + " " +
                    field.name);
  }
}

std::string type_text(const md::Field& field) {
  const std::string base = field.primitive ? std::string(md::c_name(*field.primitive)) : field.type_spelling;
  return base + (field.dynamic ? "*" : "");
}

void describe_fields(const std::vector<md::Field>& fields, bool with_offsets, std::string& out) {
  const md::StructLayout layout = md::struct_layout(fields);
  for (std::size_t i = 0; i < fields.size(); ++i) {
    const md::Field& field = fields[i];
    std::string line = "  " + type_text(field) + " " + field.name;
    if (field.count != 1) line += "[" + std::to_string(field.count) + "]";
    if (with_offsets && !field.dynamic) {
      const std::size_t element = field.primitive ? md::size_of(*field.primitive) : md::packet_size(*field.sub);
      line +=
          "  (offset " + std::to_string(layout.offsets[i]) + ", size " + std::to_string(element * field.count) + ")";
    }
    out += line + "\n";
  }
}

}  // namespace

FetchedDefinition FetchedDefinition::from_answer(const protocol::Message& answer) {
  FetchedDefinition fetched;
  try {
    fetched.name_ = answer.get_string("name");
    fetched.hash_ = answer.get_string("hash");
    fetched.names_ = answer.get_list("names");
    fetched.texts_ = answer.get_list("texts");
  } catch (const protocol::ProtocolError& error) {
    throw Failure(LNE_GOT_INVALID_RESPONSE, std::string("message definition answer: ") + error.what());
  }
  if (fetched.names_.empty() || fetched.names_.size() != fetched.texts_.size())
    throw Failure(LNE_GOT_INVALID_RESPONSE, "message definition answer without matching names and texts");
  try {
    fetched.library_ = std::make_shared<md::Library>(md::SearchPath::exactly({}));
    for (std::size_t i = 0; i < fetched.names_.size(); ++i)
      fetched.library_->add_source(fetched.names_[i], fetched.texts_[i]);
    fetched.definition_ = &fetched.library_->load(fetched.names_.front());
  } catch (const md::Error& error) {
    throw Failure(LNE_GOT_INVALID_RESPONSE,
                  "the definition '" + fetched.name_ + "' sent by the ln_manager does not parse: " + error.what());
  }
  return fetched;
}

FetchedDefinition FetchedDefinition::by_name(Client& client, const std::string& name) {
  protocol::Message request = client.new_request(protocol::method::get_message_definition);
  request.set("name", name);
  return from_answer(client.request(std::move(request)));
}

FetchedDefinition FetchedDefinition::for_topic(Client& client, const std::string& topic) {
  protocol::Message request = client.new_request(protocol::method::get_message_definition_for_topic);
  request.set("topic", client.topic_mapping().apply(topic));
  return from_answer(client.request(std::move(request)));
}

std::size_t FetchedDefinition::packet_size() const { return md::packet_size(*definition_); }

std::string FetchedDefinition::flat() const {
  if (definition_->is_dynamic()) return "<not supported by topics>";
  std::vector<std::string> lines;
  flatten(*definition_, lines);
  std::string out;
  for (const std::string& line : lines) out += line + "|";
  return out.empty() ? "|" : out;
}

std::string FetchedDefinition::describe() const {
  std::string out;
  std::vector<const md::Definition*> to_show{definition_};
  std::set<std::string> shown;
  for (std::size_t next = 0; next < to_show.size(); ++next) {
    const md::Definition& definition = *to_show[next];
    if (!shown.insert(definition.name).second) continue;
    out += "name: " + definition.name + "\n";
    out += "hash: " + definition.hash + "\n";
    out += std::string("type: ") +
           (definition.is_service() ? "service"
            : definition.is_event() ? "event"
                                    : "packet") +
           "\n";
    const bool plain = !definition.is_service() && !definition.is_event();
    if (plain) out += "size: " + std::to_string(md::packet_size(definition)) + "\n";
    if (!definition.fields.empty()) {
      out += definition.is_service() ? "request fields:\n" : definition.is_event() ? "connect fields:\n" : "fields:\n";
      describe_fields(definition.fields, plain, out);
    }
    if (!definition.response_fields.empty()) {
      out += definition.is_service() ? "response fields:\n" : "call fields:\n";
      describe_fields(definition.response_fields, false, out);
    }
    if (!definition.defines.empty()) {
      out += "non primitives:\n";
      for (const md::Define& define : definition.defines) {
        out += "  " + define.local_name + ": " + define.absolute_name + "\n";
        if (define.definition != nullptr) to_show.push_back(define.definition);
      }
    }
    out += "---\n";
  }
  return out;
}

}  // namespace ln::clientlib
