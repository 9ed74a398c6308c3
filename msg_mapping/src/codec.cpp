#include "msg_mapping/codec.hpp"

#include <algorithm>
#include <cstring>
#include <limits>
#include <map>
#include <utility>

namespace msg_mapping {
namespace {

static_assert(
    __BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__,
    "LN flat bytes are host order and the CDR we write is little-endian: big-endian hosts need byte swapping");

enum class OpCode : std::uint8_t {
  Copy,            // CDR-align, then `size` bytes identical on both sides
  Bool,            // like Copy, but LN -> CDR writes each byte as 0/1
  Zero,            // rosidl's dummy member: one zero CDR byte, nothing in LN
  String,          // LN uint32 n + n bytes      <-> CDR string
  InlineString,    // LN uint32 n + char[count]  <-> CDR string
  Sequence,        // LN uint32 n + n elements   <-> CDR uint32 n + elements
  InlineSequence,  // LN uint32 n + count elements (n used) <-> CDR sequence
  Repeat,          // `count` elements of `routine` (fixed arrays of structs)
  Opaque,          // LN T* (recursive) <-> CDR uint8[] holding its LN flat bytes
};

struct Op {
  OpCode code = OpCode::Copy;
  std::uint8_t align = 1;     // CDR alignment of the (element) data
  bool runtime_align = true;  // Copy/Bool: align at run time, else `pad` static bytes
  std::uint8_t pad = 0;
  // Sequences of 2/4/8-byte numbers: Fast DDS's size estimate aligns their
  // element block even when it is empty (see Writer).
  bool align_empty = false;
  std::uint32_t size = 0;          // Copy/Bool: bytes; memcpy-able elements: element bytes
  std::uint32_t count = 0;         // Repeat: N; InlineString/InlineSequence: LN capacity
  std::uint32_t bound = 0;         // ROS bound of a string / sequence (0: none)
  std::int32_t routine = -1;       // element routine; -1: memcpy-able elements
  std::uint32_t elem_ln_size = 0;  // InlineSequence: LN bytes per element (to skip/zero unused capacity)
  std::uint32_t field = 0;         // index into CodecProgram::names
};

struct Routine {
  std::string name;  // ROS type name, for error messages
  std::vector<Op> ops;
  bool fixed = false;        // the LN size is independent of the data (a topic packet)
  std::size_t fixed_ln = 0;  // valid when `fixed`
  std::size_t min_ln = 0;    // lower bounds, used to reject impossible counts early
  std::size_t min_cdr = 0;
};

std::string u(std::size_t v) { return std::to_string(v); }

}  // namespace

struct CodecProgram {
  std::string ros_name, ln_name;
  std::vector<Routine> routines;  // routines[0] is the top-level type
  std::vector<std::string> names;
  std::size_t fixed_ln_size = 0, fixed_cdr_size = 0;
  std::size_t trailing_zeros = 0;  // written after the message (see fastdds_plain)
};

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

// Adds the CDR bytes of `routine` starting at `pos` when they do not depend
// on the data; false otherwise.
bool cdr_is_fixed(const CodecProgram& p, int routine, std::size_t& pos);

// ------------------------------------------------------------------ cursors

struct Fail {
  [[noreturn]] static void truncated(std::size_t need, std::size_t left) {
    throw CodecError("input truncated: needs " + u(need) + " more byte(s), " + u(left) + " left");
  }
};

// Reads LN flat bytes (no alignment) or a CDR body (aligned relative to its start).
class Reader {
 public:
  Reader(const std::uint8_t* data, std::size_t size) : data_(data), size_(size) {}

  std::size_t left() const { return size_ - pos_; }
  std::size_t pos() const { return pos_; }
  const std::uint8_t* here() const { return data_ + pos_; }

  void need(std::size_t n) const {
    if (n > size_ - pos_) Fail::truncated(n, size_ - pos_);
  }
  const std::uint8_t* take(std::size_t n) {
    need(n);
    const std::uint8_t* p = data_ + pos_;
    pos_ += n;
    return p;
  }
  void align(std::size_t a) { take((a - pos_ % a) % a); }
  std::uint32_t u32() {
    std::uint32_t v;
    std::memcpy(&v, take(4), 4);
    return v;
  }

 private:
  const std::uint8_t* data_;
  std::size_t size_;
  std::size_t pos_ = 0;
};

// Fast DDS writes no alignment before the elements of an empty sequence of
// 2/4/8-byte numbers, but its size estimate (which rmw_fastrtps uses as the
// message length) counts that alignment. Sinks therefore track the estimate
// next to the real position; the difference ends the message as zero padding.

// Writes into a caller's buffer, checking its capacity on every write.
class Writer {
 public:
  Writer(std::uint8_t* data, std::size_t size) : data_(data), size_(size) {}
  std::size_t pos() const { return pos_; }
  std::size_t estimate() const { return est_; }
  void put(const std::uint8_t* src, std::size_t n) {
    std::uint8_t* p = reserve(n);
    if (n) std::memcpy(p, src, n);
    est_ += n;
  }
  void zero(std::size_t n) {
    std::uint8_t* p = reserve(n);
    if (n) std::memset(p, 0, n);
    est_ += n;
  }
  void u32(std::uint32_t v) {
    std::memcpy(reserve(4), &v, 4);
    est_ += 4;
  }
  void align(std::size_t a) {
    const std::size_t pad = (a - pos_ % a) % a;
    std::uint8_t* p = reserve(pad);
    if (pad) std::memset(p, 0, pad);
    align_estimate(a);
  }
  void align_estimate(std::size_t a) { est_ += (a - est_ % a) % a; }

 private:
  std::uint8_t* reserve(std::size_t n) {
    if (n > size_ - pos_)
      throw CodecError("output buffer too small: needs " + u(n) + " more byte(s), " + u(size_ - pos_) + " left");
    std::uint8_t* p = data_ + pos_;
    pos_ += n;
    return p;
  }

  std::uint8_t* data_;
  std::size_t size_;
  std::size_t pos_ = 0, est_ = 0;
};

// Counts what a Writer would write (the size pass).
class Counter {
 public:
  std::size_t pos() const { return pos_; }
  std::size_t estimate() const { return est_; }
  void put(const std::uint8_t*, std::size_t n) { advance(n); }
  void zero(std::size_t n) { advance(n); }
  void u32(std::uint32_t) { advance(4); }
  void align(std::size_t a) {
    pos_ += (a - pos_ % a) % a;
    align_estimate(a);
  }
  void align_estimate(std::size_t a) { est_ += (a - est_ % a) % a; }

 private:
  void advance(std::size_t n) {
    pos_ += n;
    est_ += n;
  }
  std::size_t pos_ = 0, est_ = 0;
};

constexpr int max_depth = 64;  // nesting of recursive (opaque) LN data

// Prefixes the field path to an error on its way out (only paid when failing).
[[noreturn]] void rethrow_in(const std::string& where, const CodecError& e) {
  if (where.empty()) throw e;
  throw CodecError(where + ": " + e.what());
}

// Runs `step` for each op of a routine; a failure names the field it failed in.
template <class Step>
void for_each_op(const CodecProgram& p, int routine, Step&& step) {
  for (const Op& op : p.routines[routine].ops) {
    try {
      step(op);
    } catch (const CodecError& e) {
      rethrow_in(p.names[op.field], e);
    }
  }
}

// --------------------------------------------------------------- LN -> CDR

template <class Out>
class Encoder {
 public:
  Encoder(const CodecProgram& p, Reader& in, Out& out, int depth = 0) : p_(p), in_(in), out_(out), depth_(depth) {}

  void run(int routine) {
    for_each_op(p_, routine, [this](const Op& op) { step(op); });
  }

 private:
  void elements(const Op& op, std::uint32_t n) {
    if (op.routine < 0) {
      if (n)
        out_.align(op.align);
      else if (op.align_empty)
        out_.align_estimate(op.align);
      const std::size_t bytes = std::size_t{n} * op.size;
      out_.put(in_.take(bytes), bytes);
      return;
    }
    const Routine& r = p_.routines[op.routine];
    if (r.fixed && r.fixed_ln == 0) {  // empty LN structs: only rosidl's dummy bytes, written in one go
      std::size_t per_element = 0;
      cdr_is_fixed(p_, op.routine, per_element);
      out_.zero(std::size_t{n} * per_element);
      return;
    }
    for (std::uint32_t i = 0; i < n; ++i) {
      try {
        run(op.routine);
      } catch (const CodecError& e) {
        rethrow_in("[" + u(i) + "]", e);
      }
    }
  }

  void check_count(const Op& op, std::uint32_t n, const char* what) {
    if (op.bound && n > op.bound)
      throw CodecError(std::string(what) + " of " + u(n) + " exceeds the ROS bound " + u(op.bound));
    const std::size_t min = op.routine < 0 ? op.size : p_.routines[op.routine].min_ln;
    if (op.code == OpCode::Sequence && min && n > in_.left() / min)
      throw CodecError("count " + u(n) + " is impossible: only " + u(in_.left()) + " byte(s) left");
  }

  void string(std::uint32_t n, const std::uint8_t* text) {
    out_.align(4);
    out_.u32(n + 1);
    out_.put(text, n);
    out_.zero(1);
  }

  void step(const Op& op) {
    switch (op.code) {
      case OpCode::Copy: {
        if (op.runtime_align)
          out_.align(op.align);
        else
          out_.zero(op.pad);
        out_.put(in_.take(op.size), op.size);
        return;
      }
      case OpCode::Bool: {
        if (op.runtime_align)
          out_.align(op.align);
        else
          out_.zero(op.pad);
        const std::uint8_t* src = in_.take(op.size);
        for (std::uint32_t i = 0; i < op.size; ++i) {
          const std::uint8_t b = src[i] != 0;
          out_.put(&b, 1);
        }
        return;
      }
      case OpCode::Zero:
        out_.zero(1);
        return;
      case OpCode::String: {
        const std::uint32_t n = in_.u32();
        if (op.bound && n > op.bound)
          throw CodecError("string of " + u(n) + " bytes exceeds the ROS bound " + u(op.bound));
        string(n, in_.take(n));
        return;
      }
      case OpCode::InlineString: {
        const std::uint32_t n = in_.u32();
        const std::uint8_t* text = in_.take(op.count);
        if (n > op.count) throw CodecError("LN length " + u(n) + " exceeds the capacity " + u(op.count));
        if (op.bound && n > op.bound)
          throw CodecError("string of " + u(n) + " bytes exceeds the ROS bound " + u(op.bound));
        string(n, text);
        return;
      }
      case OpCode::Sequence: {
        const std::uint32_t n = in_.u32();
        check_count(op, n, "sequence");
        out_.align(4);
        out_.u32(n);
        elements(op, n);
        return;
      }
      case OpCode::InlineSequence: {
        const std::uint32_t n = in_.u32();
        if (n > op.count) throw CodecError("LN length " + u(n) + " exceeds the capacity " + u(op.count));
        check_count(op, n, "sequence");
        out_.align(4);
        out_.u32(n);
        elements(op, n);
        in_.take(std::size_t{op.count - n} * op.elem_ln_size);  // unused capacity
        return;
      }
      case OpCode::Repeat:
        elements(op, op.count);
        return;
      case OpCode::Opaque: {
        const std::size_t start = in_.pos();
        const std::uint8_t* begin = in_.here();
        const std::uint32_t n = in_.u32();
        out_.align(4);
        if (n == 0) {  // an empty sequence is an empty byte array on the ROS side
          out_.u32(0);
          return;
        }
        walk_ln(p_, in_, op.routine, n, depth_ + 1);
        const std::size_t length = in_.pos() - start;
        if (length > std::numeric_limits<std::uint32_t>::max()) throw CodecError("recursive data beyond 4 GiB");
        out_.u32(static_cast<std::uint32_t>(length));
        out_.put(begin, length);
        return;
      }
    }
  }

 public:
  // Reads `n` LN elements of `routine` (validating them) without producing output.
  static void walk_ln(const CodecProgram& p, Reader& in, int routine, std::uint32_t n, int depth) {
    if (depth > max_depth) throw CodecError("recursive data nested deeper than " + u(max_depth) + " levels");
    const std::size_t min = p.routines[routine].min_ln;
    if (min && n > in.left() / min)
      throw CodecError("count " + u(n) + " is impossible: only " + u(in.left()) + " byte(s) left");
    Counter sink;
    Encoder<Counter> walker(p, in, sink, depth);
    for (std::uint32_t i = 0; i < n; ++i) {
      try {
        walker.run(routine);
      } catch (const CodecError& e) {
        rethrow_in("[" + u(i) + "]", e);
      }
    }
  }

 private:
  const CodecProgram& p_;
  Reader& in_;
  Out& out_;
  int depth_;
};

// --------------------------------------------------------------- CDR -> LN

template <class Out>
class Decoder {
 public:
  Decoder(const CodecProgram& p, Reader& in, Out& out) : p_(p), in_(in), out_(out) {}

  void run(int routine) {
    for_each_op(p_, routine, [this](const Op& op) { step(op); });
  }

 private:
  std::uint32_t count(const Op& op) {
    in_.align(4);
    const std::uint32_t n = in_.u32();
    if (op.bound && n > op.bound)
      throw CodecError("sequence of " + u(n) + " elements exceeds the ROS bound " + u(op.bound));
    const std::size_t min = op.routine < 0 ? op.size : p_.routines[op.routine].min_cdr;
    if (min && n > in_.left() / min)
      throw CodecError("sequence count " + u(n) + " is impossible: only " + u(in_.left()) + " byte(s) left");
    return n;
  }

  void elements(const Op& op, std::uint32_t n) {
    if (op.routine < 0) {
      if (n) in_.align(op.align);
      const std::size_t bytes = std::size_t{n} * op.size;
      out_.put(in_.take(bytes), bytes);
      return;
    }
    for (std::uint32_t i = 0; i < n; ++i) {
      try {
        run(op.routine);
      } catch (const CodecError& e) {
        rethrow_in("[" + u(i) + "]", e);
      }
    }
  }

  // CDR string -> (text, n); accepts Cyclone's length 0 for "".
  const std::uint8_t* string(std::uint32_t& n) {
    in_.align(4);
    const std::uint32_t length = in_.u32();
    if (length == 0) {
      n = 0;
      return in_.here();
    }
    const std::uint8_t* text = in_.take(length);
    if (text[length - 1] != 0) throw CodecError("string of length " + u(length) + " is not NUL-terminated");
    n = length - 1;
    return text;
  }

  void step(const Op& op) {
    switch (op.code) {
      case OpCode::Copy: {
        if (op.runtime_align)
          in_.align(op.align);
        else
          in_.take(op.pad);
        out_.put(in_.take(op.size), op.size);
        return;
      }
      case OpCode::Bool: {
        if (op.runtime_align)
          in_.align(op.align);
        else
          in_.take(op.pad);
        out_.put(in_.take(op.size), op.size);
        return;
      }
      case OpCode::Zero:
        in_.take(1);
        return;
      case OpCode::String:
      case OpCode::InlineString: {
        std::uint32_t n = 0;
        const std::uint8_t* text = string(n);
        if (op.bound && n > op.bound)
          throw CodecError("string of " + u(n) + " bytes exceeds the ROS bound " + u(op.bound));
        if (op.code == OpCode::InlineString && n > op.count)
          throw CodecError("string of " + u(n) + " bytes does not fit the LN capacity " + u(op.count) +
                           " (raise the capacity of this field)");
        out_.u32(n);
        out_.put(text, n);
        if (op.code == OpCode::InlineString) out_.zero(op.count - n);
        return;
      }
      case OpCode::Sequence: {
        const std::uint32_t n = count(op);
        out_.u32(n);
        elements(op, n);
        return;
      }
      case OpCode::InlineSequence: {
        const std::uint32_t n = count(op);
        if (n > op.count)
          throw CodecError("sequence of " + u(n) + " elements does not fit the LN capacity " + u(op.count) +
                           " (raise the capacity of this field)");
        out_.u32(n);
        elements(op, n);
        out_.zero(std::size_t{op.count - n} * op.elem_ln_size);
        return;
      }
      case OpCode::Repeat:
        elements(op, op.count);
        return;
      case OpCode::Opaque: {
        in_.align(4);
        const std::uint32_t length = in_.u32();
        if (length == 0) {
          out_.u32(0);
          return;
        }
        const std::uint8_t* bytes = in_.take(length);
        // The bytes must be exactly one LN flat sequence of the element type.
        Reader inner(bytes, length);
        try {
          const std::uint32_t n = inner.u32();
          Encoder<Counter>::walk_ln(p_, inner, op.routine, n, 1);
        } catch (const CodecError& e) {
          rethrow_in("LN flat bytes", e);
        }
        if (inner.left()) throw CodecError("LN flat bytes have " + u(inner.left()) + " byte(s) after the sequence");
        out_.put(bytes, length);
        return;
      }
    }
  }

  const CodecProgram& p_;
  Reader& in_;
  Out& out_;
};

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

void check_header(Bytes cdr) {
  if (cdr.size < cdr_header_size) throw CodecError("CDR input of " + u(cdr.size) + " byte(s) lacks the 4-byte header");
  if (cdr.data[0] != 0x00 || cdr.data[1] != 0x01) {
    if (cdr.data[0] == 0x00 && cdr.data[1] == 0x00) throw CodecError("big-endian CDR (header 00 00) is not supported");
    throw CodecError("unsupported CDR encapsulation " + u(cdr.data[0]) + "," + u(cdr.data[1]) +
                     " (expected 00 01: plain CDR, little-endian)");
  }
}

}  // namespace

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

namespace {

template <class Out>
void encode(const CodecProgram& p, Bytes ln, Out& out) {
  if (p.fixed_ln_size && ln.size != p.fixed_ln_size)
    throw CodecError(p.ros_name + ": LN message of " + u(ln.size) + " bytes, expected " + u(p.fixed_ln_size) + " (" +
                     p.ln_name + ")");
  Reader in(ln.data, ln.size);
  try {
    Encoder<Out>(p, in, out).run(0);
  } catch (const CodecError& e) {
    rethrow_in(p.ros_name, e);
  }
  if (in.left())
    throw CodecError(p.ros_name + ": " + u(in.left()) + " byte(s) left over after the LN message (" + p.ln_name + ")");
}

template <class Out>
void decode(const CodecProgram& p, Bytes cdr, Out& out) {
  check_header(cdr);
  Reader in(cdr.data + cdr_header_size, cdr.size - cdr_header_size);
  try {
    Decoder<Out>(p, in, out).run(0);
  } catch (const CodecError& e) {
    rethrow_in(p.ros_name, e);
  }
}

}  // namespace

std::size_t Codec::cdr_size(Bytes ln) const {
  if (program_->fixed_cdr_size) {
    if (ln.size != program_->fixed_ln_size)
      throw CodecError(program_->ros_name + ": LN message of " + u(ln.size) + " bytes, expected " +
                       u(program_->fixed_ln_size) + " (" + program_->ln_name + ")");
    return program_->fixed_cdr_size;
  }
  Counter counter;
  encode(*program_, ln, counter);
  return cdr_header_size + counter.estimate();
}

std::size_t Codec::ln_to_cdr(Bytes ln, MutableBytes out) const {
  if (out.size < cdr_header_size) throw CodecError("output buffer too small for the CDR header");
  static constexpr std::uint8_t header[cdr_header_size] = {0x00, 0x01, 0x00, 0x00};
  std::memcpy(out.data, header, cdr_header_size);
  Writer writer(out.data + cdr_header_size, out.size - cdr_header_size);
  encode(*program_, ln, writer);
  writer.zero(writer.estimate() - writer.pos() + program_->trailing_zeros);
  return cdr_header_size + writer.pos();
}

std::vector<std::uint8_t> Codec::ln_to_cdr(Bytes ln) const {
  std::vector<std::uint8_t> out(cdr_size(ln));
  ln_to_cdr(ln, {out.data(), out.size()});
  return out;
}

std::size_t Codec::ln_size(Bytes cdr) const {
  Counter counter;
  decode(*program_, cdr, counter);
  return counter.pos();
}

std::size_t Codec::cdr_to_ln(Bytes cdr, MutableBytes out) const {
  Writer writer(out.data, out.size);
  decode(*program_, cdr, writer);
  return writer.pos();
}

std::vector<std::uint8_t> Codec::cdr_to_ln(Bytes cdr) const {
  std::vector<std::uint8_t> out(program_->fixed_ln_size ? program_->fixed_ln_size : ln_size(cdr));
  const std::size_t n = cdr_to_ln(cdr, {out.data(), out.size()});
  out.resize(n);
  return out;
}

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
