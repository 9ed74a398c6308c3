// LN flat bytes -> CDR: runs a CodecProgram over an LN packet into a
// buffer (Writer) or only to size it (Counter).
#include "codec_program.hpp"

namespace msg_mapping {
namespace codec_detail {
namespace {

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
    for_each_element(n, [&] { run(op.routine); });
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
      case OpCode::Copy:
        put_cdr_padding(out_, op);
        out_.put(in_.take(op.size), op.size);
        return;
      case OpCode::Bool: {
        put_cdr_padding(out_, op);
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
    for_each_element(n, [&] { walker.run(routine); });
  }

 private:
  const CodecProgram& p_;
  Reader& in_;
  Out& out_;
  int depth_;
};

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

}  // namespace

void walk_ln_elements(const CodecProgram& p, Reader& in, int routine, std::uint32_t n) {
  Encoder<Counter>::walk_ln(p, in, routine, n, 1);
}

}  // namespace codec_detail

using namespace codec_detail;

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

}  // namespace msg_mapping
