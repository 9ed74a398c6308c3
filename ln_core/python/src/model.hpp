// The md model as Python data (see model.cpp).
#pragma once

#include <functional>
#include <optional>
#include <string>

#include <nanobind/nanobind.h>

#include "ln/md/message_definition.hpp"

namespace lnpy {

/// Text of a definition by name, or nothing when unknown.
using Fetch = std::function<std::optional<std::string>(const std::string&)>;

/// `definition` and everything it imports as Python dicts.
nanobind::dict definition_to_python(const ln::md::Definition& definition);

/// Rebuilds definition `name` (with `root_text` as its text, or fetched)
/// from texts obtained through `fetch`, using the md parser to learn the
/// imports. Throws ln::md::Error.
nanobind::dict build_model(const std::string& name, const std::optional<std::string>& root_text, const Fetch& fetch);

}  // namespace lnpy
