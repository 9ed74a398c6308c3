// CDR -> LN flat bytes: checks the encapsulation header, then runs a
// CodecProgram over the CDR body into a buffer (Writer) or only to size it.
#include "codec_program.hpp"

namespace msg_mapping {
namespace codec_detail {
namespace {

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
    for_each_element(n, [&] { run(op.routine); });
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
      case OpCode::Copy:
      case OpCode::Bool:  // one byte on both sides: copied as it is
        skip_cdr_padding(in_, op);
        out_.put(in_.take(op.size), op.size);
        return;
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
          walk_ln_elements(p_, inner, op.routine, n);
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

void check_header(Bytes cdr) {
  if (cdr.size < cdr_header_size) throw CodecError("CDR input of " + u(cdr.size) + " byte(s) lacks the 4-byte header");
  if (cdr.data[0] != 0x00 || cdr.data[1] != 0x01) {
    if (cdr.data[0] == 0x00 && cdr.data[1] == 0x00) throw CodecError("big-endian CDR (header 00 00) is not supported");
    throw CodecError("unsupported CDR encapsulation " + u(cdr.data[0]) + "," + u(cdr.data[1]) +
                     " (expected 00 01: plain CDR, little-endian)");
  }
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
}  // namespace codec_detail

using namespace codec_detail;

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

}  // namespace msg_mapping
