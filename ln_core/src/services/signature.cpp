#include "services/signature.hpp"

#include <cctype>
#include <optional>

#define NO_CPP_WRAPPER
#include "ln/ln.h"

namespace ln::services {
namespace {

// Signatures come from generated headers, the manager and peers; these
// bounds keep a hostile one from exhausting the stack or overflowing sizes.
constexpr unsigned max_signature_nesting = 64;
constexpr std::uint64_t max_host_struct_size = std::uint64_t{1} << 31;

struct ParsedField {
  std::optional<md::Primitive> primitive;
  int sub = -1;            // program index of a sub-type (also for "[]")
  bool recursive = false;  // "[]": the enclosing type itself
  bool dynamic = false;
  std::uint64_t count = 1;
  int companion = -1;  // dynamic: index of its count field
  bool is_companion = false;
};

bool can_hold_count(const ParsedField& f) {
  // char is excluded: its signedness differs between platforms.
  return f.primitive && md::is_integer(*f.primitive) && *f.primitive != md::Primitive::Char && !f.dynamic &&
         f.count == 1;
}

class Compiler {
 public:
  Compiler(std::string_view text, bool swap_bytes, std::vector<StructProgram>& programs)
      : text_(text), swap_bytes_(swap_bytes), programs_(programs) {}

  Status compile_side() {
    int index = -1;
    Status s = parse_struct(index, '\0', 0);
    if (!s.ok()) return s;
    if (pos_ != text_.size()) return error("unexpected '" + std::string(1, text_[pos_]) + "'");
    return s;
  }

 private:
  Status error(const std::string& what) const {
    return Status::failure(LNE_INVALID_SIGNATURE, "invalid signature '" + std::string(text_) + "' at position " +
                                                      std::to_string(pos_) + ": " + what);
  }

  bool at_end() const { return pos_ >= text_.size(); }
  char peek() const { return at_end() ? '\0' : text_[pos_]; }
  void skip_spaces() {
    while (peek() == ' ' || peek() == '\t') ++pos_;
  }

  // A struct's fields up to `terminator` ('\0' = end of text, else ']').
  Status parse_struct(int& index, char terminator, unsigned depth) {
    if (depth > max_signature_nesting) return error("sub-types nested too deeply");
    index = static_cast<int>(programs_.size());
    programs_.emplace_back();
    std::vector<ParsedField> fields;
    skip_spaces();
    const bool empty = terminator == '\0' ? at_end() : peek() == terminator;
    // "[]" never reaches here, so only a side may have no fields.
    if (empty && terminator != '\0') return error("empty sub-type");
    while (!empty) {
      ParsedField f;
      Status s = parse_field(f, index, depth);
      if (!s.ok()) return s;
      fields.push_back(f);
      skip_spaces();
      if (peek() != ',') break;
      ++pos_;
    }
    if (terminator != '\0') {
      if (peek() != terminator) return error("expected ',' or ']'");
      ++pos_;
    }
    return lay_out(index, fields);
  }

  Status parse_field(ParsedField& f, int enclosing, unsigned depth) {
    skip_spaces();
    if (peek() == '[') {
      ++pos_;
      if (peek() == ']') {
        ++pos_;
        f.recursive = true;
        f.sub = enclosing;
      } else {
        Status s = parse_struct(f.sub, ']', depth + 1);
        if (!s.ok()) return s;
      }
    } else {
      const std::size_t start = pos_;
      while (!at_end() && (std::isalnum(static_cast<unsigned char>(peek())) || peek() == '_')) ++pos_;
      const std::string_view name = text_.substr(start, pos_ - start);
      if (name.empty()) return error("expected a type");
      f.primitive = md::primitive_from_spelling(name);
      if (!f.primitive) return error("unknown type '" + std::string(name) + "'");
    }
    if (peek() == '*') {
      ++pos_;
      f.dynamic = true;
    }
    std::uint64_t element_size = 0;
    Status s = parse_number(element_size, "element size");
    if (!s.ok()) return s;
    s = parse_number(f.count, "count");
    if (!s.ok()) return s;

    if (f.recursive && !f.dynamic) return error("'[]' (the enclosing type) is only possible behind a pointer");
    if (f.primitive && element_size != md::size_of(*f.primitive))
      return error(std::string(md::c_name(*f.primitive)) + " has " + std::to_string(md::size_of(*f.primitive)) +
                   " bytes, not " + std::to_string(element_size));
    if (f.count == 0) return error("count 0");
    if (f.dynamic && f.count != 1) return error("arrays of pointers are not supported");
    return {};
  }

  Status parse_number(std::uint64_t& value, const char* what) {
    const std::size_t before_spaces = pos_;
    skip_spaces();
    if (pos_ == before_spaces) return error(std::string("expected a blank before the ") + what);
    const std::size_t start = pos_;
    value = 0;
    while (!at_end() && peek() >= '0' && peek() <= '9') {
      if (pos_ - start >= 12) return error(std::string(what) + " too large");
      value = value * 10 + static_cast<std::uint64_t>(peek() - '0');
      ++pos_;
    }
    if (pos_ == start) return error(std::string("expected the ") + what);
    return {};
  }

  // Host offsets, count companions and steps of program `index`.
  Status lay_out(int index, std::vector<ParsedField>& fields) {
    const std::size_t n = fields.size();
    for (std::size_t i = 1; i < n; ++i)
      if (fields[i].dynamic && can_hold_count(fields[i - 1]) && !fields[i - 1].is_companion) {
        fields[i].companion = static_cast<int>(i - 1);
        fields[i - 1].is_companion = true;
      }
    for (std::size_t i = 0; i < n; ++i) {
      if (!fields[i].dynamic || fields[i].companion >= 0) continue;
      if (i + 1 < n && can_hold_count(fields[i + 1]) && !fields[i + 1].is_companion) {
        fields[i].companion = static_cast<int>(i + 1);
        fields[i + 1].is_companion = true;
      } else {
        return error("dynamic field " + std::to_string(i + 1) + " has no integer length field next to it");
      }
    }

    std::vector<std::uint32_t> offsets(n);
    std::uint64_t host_size = 0;
    for (std::size_t i = 0; i < n; ++i) {
      const ParsedField& f = fields[i];
      std::uint64_t element = 0;
      if (f.dynamic)
        element = sizeof(void*);
      else if (f.primitive)
        element = md::size_of(*f.primitive);
      else
        element = programs_[static_cast<std::size_t>(f.sub)].host_size;
      offsets[i] = static_cast<std::uint32_t>(host_size);
      host_size += element * f.count;  // both factors < 2^32: no overflow
      if (host_size > max_host_struct_size) return error("struct larger than 2 GiB");
    }

    StructProgram program;
    program.host_size = static_cast<std::size_t>(host_size);
    for (std::size_t i = 0; i < n; ++i) {
      const ParsedField& f = fields[i];
      if (f.is_companion) continue;
      if (f.dynamic) {
        Step step;
        step.kind = Step::Kind::Dynamic;
        step.host_offset = offsets[i];
        step.count_offset = offsets[static_cast<std::size_t>(f.companion)];
        step.count_type = *fields[static_cast<std::size_t>(f.companion)].primitive;
        if (f.primitive) {
          step.size = md::size_of(*f.primitive);
          step.swap_unit = static_cast<std::uint8_t>(swap_bytes_ ? step.size : 1);
          step.element_align = static_cast<std::uint8_t>(step.size);
        } else if (!f.recursive && raw_bytes(f.sub)) {
          step.size = programs_[static_cast<std::size_t>(f.sub)].host_size;
        } else {
          step.program = f.sub;
        }
        program.steps.push_back(step);
        program.fixed = false;
        program.min_wire_size += 4;
      } else if (f.primitive) {
        const std::size_t element = md::size_of(*f.primitive);
        append_copy(program, offsets[i], element * f.count, swap_bytes_ ? element : 1);
        program.min_wire_size += element * f.count;
      } else {
        const StructProgram& sub = programs_[static_cast<std::size_t>(f.sub)];
        if (raw_bytes(f.sub)) {
          append_copy(program, offsets[i], sub.host_size * f.count, 1);
        } else {
          Step step;
          step.kind = Step::Kind::Structs;
          step.host_offset = offsets[i];
          step.size = static_cast<std::size_t>(f.count);
          step.program = f.sub;
          program.steps.push_back(step);
        }
        program.fixed = program.fixed && sub.fixed;
        program.min_wire_size += sub.min_wire_size * f.count;
      }
    }
    programs_[static_cast<std::size_t>(index)] = std::move(program);
    return {};
  }

  // Whether instances of program `index` travel as their host bytes.
  bool raw_bytes(int index) const { return !swap_bytes_ && programs_[static_cast<std::size_t>(index)].fixed; }

  static void append_copy(StructProgram& program, std::uint32_t offset, std::size_t bytes, std::size_t unit) {
    if (!program.steps.empty()) {
      Step& last = program.steps.back();
      if (last.kind == Step::Kind::Copy && last.swap_unit == unit && last.host_offset + last.size == offset) {
        last.size += bytes;
        return;
      }
    }
    Step step;
    step.kind = Step::Kind::Copy;
    step.host_offset = offset;
    step.size = bytes;
    step.swap_unit = static_cast<std::uint8_t>(unit);
    program.steps.push_back(step);
  }

  std::string_view text_;
  bool swap_bytes_;
  std::vector<StructProgram>& programs_;
  std::size_t pos_ = 0;
};

// Position of the '|' between request and response (outside brackets), or
// npos if there is none or more than one.
std::size_t find_separator(std::string_view signature) {
  std::size_t found = std::string_view::npos;
  int depth = 0;
  for (std::size_t i = 0; i < signature.size(); ++i) {
    const char c = signature[i];
    if (c == '[') ++depth;
    if (c == ']') --depth;
    if (c == '|' && depth == 0) {
      if (found != std::string_view::npos) return std::string_view::npos;
      found = i;
    }
  }
  return found;
}

}  // namespace

Status MessageLayout::compile(std::string_view side_signature, MessageLayout& out, bool swap_bytes) {
  std::vector<StructProgram> programs;
  Status s = Compiler(side_signature, swap_bytes, programs).compile_side();
  if (s.ok()) out.programs_ = std::move(programs);
  return s;
}

Status ServiceSignature::compile(std::string_view signature, ServiceSignature& out, bool swap_bytes) {
  const std::size_t bar = find_separator(signature);
  if (bar == std::string_view::npos)
    return Status::failure(LNE_INVALID_SIGNATURE, "invalid service signature '" + std::string(signature) +
                                                      "': needs exactly one '|' between request and response");
  ServiceSignature compiled;
  Status s = MessageLayout::compile(signature.substr(0, bar), compiled.request_, swap_bytes);
  if (s.ok()) s = MessageLayout::compile(signature.substr(bar + 1), compiled.response_, swap_bytes);
  if (!s.ok()) return s;
  compiled.text_ = std::string(signature);
  out = std::move(compiled);
  return {};
}

Status ServiceSignature::compile_shared(std::string_view signature, std::shared_ptr<const ServiceSignature>& out) {
  auto compiled = std::make_shared<ServiceSignature>();
  Status s = compile(signature, *compiled);
  if (s.ok()) out = std::move(compiled);
  return s;
}

bool same_signature(std::string_view registered, const char* given) { return given != nullptr && registered == given; }

}  // namespace ln::services
