#pragma once

#include <string>

#include "ln/md/message_definition.hpp"

namespace ln::md {

/// The definition hash exactly as LN 2.9 computes it, so that "name|hash"
/// strings from LN 2.9 programs and ours agree: SHA-256 over the Python
/// repr() of (fields, response_fields, sorted local defines -> their fields).
std::string compute_definition_hash(const Definition& definition);

}  // namespace ln::md
