// Compiles a PairedType into a CodecProgram, and what a program tells
// without running it (fixed sizes, Fast DDS's "plain" padding, describe()).
#include <algorithm>
#include <map>
#include <utility>

#include "codec_program.hpp"

namespace msg_mapping {
namespace codec_detail {

bool cdr_is_fixed(const CodecProgram& p, int routine, std::size_t& pos) {
  for (const Op& op : p.routines[routine].ops) {
    switch (op.code) {
      case OpCode::Copy:
      case OpCode::Bool:
        pos += op.runtime_align ? (op.align - pos % op.align) % op.align : op.pad;
        pos += op.size;
        break;
      case OpCode::Zero:
        pos += 1;
        break;
      case OpCode::Repeat:
        for (std::uint32_t i = 0; i < op.count; ++i)
          if (!cdr_is_fixed(p, op.routine, pos)) return false;
        break;
      default:
        return false;
    }
  }
  return true;
}

namespace {

// ------------------------------------------------------------------ compiler

// Position modulo `mod` (1, 2, 4 or 8) is `rem`: what is known at compile
// time about the CDR offset, so alignment padding can be decided statically.
struct Phase {
  std::size_t mod = 1, rem = 0;
  static Phase unknown() { return {1, 0}; }
  void advance(std::size_t n) { rem = (rem + n) % mod; }
};

class Compiler {
 public:
  explicit Compiler(CodecProgram& program) : p_(program) {}

  int routine_for(const PairedType& type) {
    if (auto it = routine_of_.find(&type); it != routine_of_.end()) return it->second;
    const int index = static_cast<int>(p_.routines.size());
    routine_of_[&type] = index;
    p_.routines.push_back({});
    p_.routines[index].name = type.ros_name;
    const std::string outer_prefix = std::exchange(prefix_, "");
    std::vector<Op> ops;
    compile_struct(type, Phase::unknown(), ops);
    prefix_ = outer_prefix;
    finish(index, std::move(ops));
    return index;
  }

  void compile_top(const PairedType& type) {
    p_.routines.push_back({});
    p_.routines[0].name = type.ros_name;
    std::vector<Op> ops;
    compile_struct(type, Phase{8, 0}, ops);  // CDR alignment restarts after the encapsulation header
    finish(0, std::move(ops));
  }

 private:
  std::uint32_t name(const std::string& n) {
    p_.names.push_back(prefix_ + n);
    return static_cast<std::uint32_t>(p_.names.size() - 1);
  }

  // Appends a Copy/Bool op with the padding known statically when possible.
  void emit_block(OpCode code, std::size_t align, std::size_t size, std::uint32_t field, Phase& phase,
                  std::vector<Op>& ops) {
    Op op;
    op.code = code;
    op.align = static_cast<std::uint8_t>(align);
    op.size = static_cast<std::uint32_t>(size);
    op.field = field;
    if (phase.mod >= align) {
      op.runtime_align = false;
      op.pad = static_cast<std::uint8_t>((align - phase.rem % align) % align);
      phase.advance(op.pad);
    } else {
      phase = Phase{align, 0};
    }
    phase.advance(size);
    ops.push_back(op);
  }

  Phase compile_struct(const PairedType& type, Phase phase, std::vector<Op>& ops) {
    if (type.ros_dummy_member) {
      Op op;
      op.code = OpCode::Zero;
      op.field = name("structure_needs_at_least_one_member");
      ops.push_back(op);
      phase.advance(1);
      return phase;
    }
    for (const PairedField& f : type.fields) phase = compile_field(f, phase, ops);
    return phase;
  }

  // Maximum and first CDR alignment of a struct made only of fixed fields.
  static void alignments(const PairedType& type, std::size_t& max_align, std::size_t& first_align) {
    if (type.ros_dummy_member) {
      max_align = std::max<std::size_t>(max_align, 1);
      if (!first_align) first_align = 1;
    }
    for (const PairedField& f : type.fields) {
      if (f.element == ElementKind::Struct) {
        alignments(*f.struct_type, max_align, first_align);
      } else {
        const std::size_t a = f.element == ElementKind::String ? 4 : cdr_size(f.ros_primitive);
        max_align = std::max(max_align, a);
        if (!first_align) first_align = a;
      }
    }
  }

  // A struct whose LN and CDR bytes are identical when it starts aligned, and
  // stays so element after element: arrays of it are one memcpy.
  bool dense(const PairedType& type, std::size_t& size, std::size_t& align) {
    std::vector<Op> ops;
    compile_struct(type, Phase{8, 0}, ops);
    merge(ops);
    if (ops.size() != 1 || ops[0].code != OpCode::Copy || ops[0].pad != 0 || ops[0].runtime_align) return false;
    std::size_t max_align = 1, first_align = 0;
    alignments(type, max_align, first_align);
    if (first_align != max_align || ops[0].size % max_align != 0) return false;
    size = ops[0].size;
    align = max_align;
    return true;
  }

  // The routine converting one element of a string/struct/bool field.
  int element_routine(const PairedField& f) {
    if (f.element == ElementKind::Struct) return routine_for(*f.struct_type);
    const std::string key =
        f.element == ElementKind::String ? "string:" + u(f.string_capacity) + ":" + u(f.ros_string_bound) : "bool";
    if (auto it = element_routines_.find(key); it != element_routines_.end()) return it->second;
    const int index = static_cast<int>(p_.routines.size());
    element_routines_[key] = index;
    p_.routines.push_back({});
    p_.routines[index].name = f.element == ElementKind::String ? "string" : "bool";
    PairedField single = f;
    single.shape = Shape::Single;
    single.ros_name = "";
    const std::string outer_prefix = std::exchange(prefix_, "");
    std::vector<Op> ops;
    compile_field(single, Phase::unknown(), ops);
    prefix_ = outer_prefix;
    finish(index, std::move(ops));
    return index;
  }

  Phase compile_field(const PairedField& f, Phase phase, std::vector<Op>& ops) {
    const std::uint32_t field = name(f.ros_name);
    switch (f.shape) {
      case Shape::Single:
      case Shape::FixedArray: {
        const std::uint32_t n = f.shape == Shape::Single ? 1 : f.count;
        if (f.element == ElementKind::Primitive) {
          const std::size_t size = cdr_size(f.ros_primitive);
          emit_block(f.ros_primitive == RosPrimitive::Bool ? OpCode::Bool : OpCode::Copy, size, size * n, field, phase,
                     ops);
          return phase;
        }
        if (f.element == ElementKind::String && n == 1) {
          Op op;
          op.code = f.string_capacity ? OpCode::InlineString : OpCode::String;
          op.count = f.string_capacity;
          op.bound = f.ros_string_bound;
          op.field = field;
          ops.push_back(op);
          return Phase::unknown();
        }
        if (f.element == ElementKind::Struct) {
          std::size_t size = 0, align = 1;
          if (dense(*f.struct_type, size, align)) {
            emit_block(OpCode::Copy, align, size * n, field, phase, ops);
            return phase;
          }
          if (n == 1) {  // inlined: its fields are named "field.member" in errors
            const std::size_t outer = prefix_.size();
            prefix_ += f.ros_name + ".";
            phase = compile_struct(*f.struct_type, phase, ops);
            prefix_.resize(outer);
            return phase;
          }
        }
        Op op;
        op.code = OpCode::Repeat;
        op.count = n;
        op.routine = element_routine(f);
        op.field = field;
        ops.push_back(op);
        return Phase::unknown();
      }
      case Shape::Sequence:
      case Shape::InlineSequence: {
        Op op;
        op.code = f.shape == Shape::Sequence ? OpCode::Sequence : OpCode::InlineSequence;
        op.count = f.shape == Shape::InlineSequence ? f.count : 0;
        op.bound = f.ros_bound;
        op.field = field;
        std::size_t size = 0, align = 1;
        if (f.element == ElementKind::Primitive && f.ros_primitive != RosPrimitive::Bool) {
          op.size = static_cast<std::uint32_t>(cdr_size(f.ros_primitive));
          op.align = static_cast<std::uint8_t>(op.size);
          op.align_empty = true;
        } else if (f.element == ElementKind::Struct && dense(*f.struct_type, size, align)) {
          op.size = static_cast<std::uint32_t>(size);
          op.align = static_cast<std::uint8_t>(align);
        } else {
          op.routine = element_routine(f);
        }
        if (op.code == OpCode::InlineSequence)
          op.elem_ln_size = static_cast<std::uint32_t>(op.routine < 0 ? op.size : p_.routines[op.routine].fixed_ln);
        ops.push_back(op);
        return Phase::unknown();
      }
      case Shape::Opaque: {
        Op op;
        op.code = OpCode::Opaque;
        op.routine = routine_for(*f.struct_type);
        op.field = field;
        ops.push_back(op);
        return Phase::unknown();
      }
    }
    return Phase::unknown();
  }

  // Copies that follow each other without padding become one memcpy.
  void merge(std::vector<Op>& ops) {
    std::vector<Op> out;
    for (const Op& op : ops) {
      if (!out.empty() && out.back().code == OpCode::Copy && op.code == OpCode::Copy && !op.runtime_align &&
          op.pad == 0 && std::uint64_t{out.back().size} + op.size <= std::numeric_limits<std::uint32_t>::max()) {
        Op& last = out.back();
        const std::string merged =
            p_.names[last.field].substr(0, p_.names[last.field].find("..")) + ".." + p_.names[op.field];
        last.size += op.size;
        p_.names.push_back(merged);
        last.field = static_cast<std::uint32_t>(p_.names.size() - 1);
        continue;
      }
      out.push_back(op);
    }
    ops = std::move(out);
  }

  void finish(int index, std::vector<Op> ops) {
    merge(ops);
    Routine& r = p_.routines[index];
    r.ops = std::move(ops);
    // Sizes: fixed when every op is; minimums for count sanity checks.
    bool fixed = true;
    std::size_t ln = 0, min_ln = 0, min_cdr = 0;
    for (const Op& op : r.ops) {
      switch (op.code) {
        case OpCode::Copy:
        case OpCode::Bool:
          ln += op.size;
          min_ln += op.size;
          min_cdr += op.size;
          break;
        case OpCode::Zero:
          min_cdr += 1;
          break;
        case OpCode::String:
          fixed = false;
          min_ln += 4;
          min_cdr += 4;
          break;
        case OpCode::InlineString:
          ln += 4 + op.count;
          min_ln += 4 + op.count;
          min_cdr += 4;
          break;
        case OpCode::Sequence:
        case OpCode::Opaque:
          fixed = false;
          min_ln += 4;
          min_cdr += 4;
          break;
        case OpCode::InlineSequence:
          ln += 4 + std::size_t{op.count} * op.elem_ln_size;
          min_ln += 4 + std::size_t{op.count} * op.elem_ln_size;
          min_cdr += 4;
          break;
        case OpCode::Repeat: {
          const Routine& e = p_.routines[op.routine];
          if (!e.fixed) fixed = false;
          ln += std::size_t{op.count} * e.fixed_ln;
          min_ln += std::size_t{op.count} * e.min_ln;
          min_cdr += std::size_t{op.count} * e.min_cdr;
          break;
        }
      }
    }
    r.fixed = fixed;
    r.fixed_ln = ln;
    r.min_ln = min_ln;
    r.min_cdr = min_cdr;
  }

  CodecProgram& p_;
  std::string prefix_;  // path of the struct being inlined ("header.")
  std::map<const PairedType*, int> routine_of_;
  std::map<std::string, int> element_routines_;
};

// ------------------------------------------------- Fast DDS "plain" types

// rmw_fastrtps sizes the serialization of a "plain" type (fixed size, and its
// C struct has the CDR layout) with its maximum size rounded up to 4 bytes, so
// rclpy's serialize_message ends such messages with up to 3 padding bytes. We
// reproduce the check of rosidl_typesupport_fastrtps_c's max_serialized_size_*
// to produce the same length.
std::size_t align_up(std::size_t v, std::size_t a) { return (v + a - 1) / a * a; }

struct CLayout {
  std::size_t size = 0, align = 1, last_offset = 0;
};

// The rosidl C struct of a (plain) type: natural alignment, fields in order.
CLayout c_layout(const PairedType& type) {
  CLayout layout;
  auto add = [&](std::size_t size, std::size_t align) {
    layout.last_offset = align_up(layout.size, align);
    layout.size = layout.last_offset + size;
    layout.align = std::max(layout.align, align);
  };
  if (type.ros_dummy_member) add(1, 1);
  for (const PairedField& f : type.fields) {
    const std::size_t n = f.shape == Shape::FixedArray ? f.count : 1;
    if (f.element == ElementKind::Struct) {
      const CLayout inner = c_layout(*f.struct_type);
      add(inner.size * n, inner.align);
    } else {
      const std::size_t s = cdr_size(f.ros_primitive);
      add(s * n, s);
    }
  }
  layout.size = align_up(layout.size, layout.align);
  return layout;
}

// max_serialized_size_* of rosidl_typesupport_fastrtps_c: the CDR size from
// `position`, and whether the type is plain there.
bool fastdds_plain(const PairedType& type, std::size_t& position) {
  const std::size_t initial = position;
  std::size_t last_member_size = 0;
  if (type.ros_dummy_member) {
    last_member_size = 1;
    position += 1;
  }
  for (const PairedField& f : type.fields) {
    if (f.shape != Shape::Single && f.shape != Shape::FixedArray) return false;
    if (f.element == ElementKind::String) return false;
    const std::size_t n = f.shape == Shape::FixedArray ? f.count : 1;
    if (f.element == ElementKind::Struct) {
      last_member_size = 0;
      for (std::size_t i = 0; i < n; ++i) {
        const std::size_t before = position;
        if (!fastdds_plain(*f.struct_type, position)) return false;
        last_member_size += position - before;
      }
    } else {
      const std::size_t s = cdr_size(f.ros_primitive);
      last_member_size = n * s;
      position += (s - position % s) % s + n * s;
    }
  }
  return c_layout(type).last_offset + last_member_size == position - initial;
}

const char* op_name(OpCode code) {
  switch (code) {
    case OpCode::Copy:
      return "copy";
    case OpCode::Bool:
      return "bool";
    case OpCode::Zero:
      return "zero";
    case OpCode::String:
      return "string";
    case OpCode::InlineString:
      return "inline_string";
    case OpCode::Sequence:
      return "sequence";
    case OpCode::InlineSequence:
      return "inline_sequence";
    case OpCode::Repeat:
      return "repeat";
    case OpCode::Opaque:
      return "opaque";
  }
  return "?";
}

}  // namespace
}  // namespace codec_detail

using namespace codec_detail;

Codec::Codec(const PairedType& type) : program_(std::make_unique<CodecProgram>()) {
  program_->ros_name = type.ros_name;
  program_->ln_name = type.ln_name;
  Compiler compiler(*program_);
  compiler.compile_top(type);
  const Routine& top = program_->routines[0];
  if (top.fixed) {
    program_->fixed_ln_size = top.fixed_ln;  // strings and sequences with capacities still vary on the CDR side
    std::size_t pos = 0;
    if (cdr_is_fixed(*program_, 0, pos)) {
      program_->fixed_cdr_size = cdr_header_size + pos;
      std::size_t position = 0;
      if (fastdds_plain(type, position)) {
        program_->trailing_zeros = align_up(program_->fixed_cdr_size, 4) - program_->fixed_cdr_size;
        program_->fixed_cdr_size += program_->trailing_zeros;
      }
    }
  }
}

Codec::~Codec() = default;
Codec::Codec(Codec&&) noexcept = default;
Codec& Codec::operator=(Codec&&) noexcept = default;

const std::string& Codec::ros_name() const { return program_->ros_name; }
const std::string& Codec::ln_name() const { return program_->ln_name; }
std::size_t Codec::fixed_ln_size() const { return program_->fixed_ln_size; }
std::size_t Codec::fixed_cdr_size() const { return program_->fixed_cdr_size; }

std::string Codec::describe() const {
  std::string out;
  for (std::size_t r = 0; r < program_->routines.size(); ++r) {
    const Routine& routine = program_->routines[r];
    out += "routine " + u(r) + " " + routine.name + (routine.fixed ? " fixed ln=" + u(routine.fixed_ln) : "") + "\n";
    for (const Op& op : routine.ops) {
      out += "  " + std::string(op_name(op.code)) + " " + program_->names[op.field];
      if (op.code == OpCode::Copy || op.code == OpCode::Bool)
        out += " size=" + u(op.size) + (op.runtime_align ? " align=" + u(op.align) : " pad=" + u(op.pad));
      if (op.count) out += " count=" + u(op.count);
      if (op.bound) out += " bound=" + u(op.bound);
      if (op.routine >= 0)
        out += " routine=" + u(static_cast<std::size_t>(op.routine));
      else if (op.code == OpCode::Sequence || op.code == OpCode::InlineSequence)
        out += " elem=" + u(op.size) + " align=" + u(op.align);
      out += "\n";
    }
  }
  return out;
}

}  // namespace msg_mapping
