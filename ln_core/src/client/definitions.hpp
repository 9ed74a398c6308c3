// Message-definition queries of the C API. The manager resolves names on its
// search path and answers with the definition's text plus the texts of
// everything it imports; the client rebuilds the model from them (same
// parser, same hashes) to compute sizes, layouts and descriptions itself.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "ln/md/message_definition.hpp"
#include "protocol/wire.hpp"

namespace ln::clientlib {

class Client;

/// A definition as the manager knows it, rebuilt in memory.
class FetchedDefinition {
 public:
  /// get_message_definition (a "name" or "name|hash"). Throws Failure.
  static FetchedDefinition by_name(Client& client, const std::string& name);
  /// get_message_definition_for_topic (name mapping applied). Throws Failure.
  static FetchedDefinition for_topic(Client& client, const std::string& topic);

  const std::string& name() const { return name_; }
  const std::string& hash() const { return hash_; }
  /// The definition's own text, as in its file.
  const std::string& text() const { return texts_.front(); }
  const md::Definition& definition() const { return *definition_; }
  /// Bytes of one packet on a topic.
  std::size_t packet_size() const;
  /// LN's flattened form ("type_id size count name|...|"), or
  /// "<not supported by topics>" for definitions with dynamic fields.
  std::string flat() const;
  /// Readable description: every definition involved with its fields,
  /// offsets and sizes.
  std::string describe() const;

 private:
  static FetchedDefinition from_answer(const protocol::Message& answer);
  std::string name_;
  std::string hash_;
  std::vector<std::string> names_;
  std::vector<std::string> texts_;
  std::shared_ptr<md::Library> library_;
  const md::Definition* definition_ = nullptr;
};

}  // namespace ln::clientlib
