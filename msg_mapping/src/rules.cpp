#include "msg_mapping/rules.hpp"

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <set>

#include "text_util.hpp"

namespace msg_mapping {

namespace md = ln::md;

enum class MoveKind : std::uint8_t {
  Number,       // one number (LN value or constant) -> one ROS number
  Array,        // LN numeric array -> ROS fixed array (same count) or inline sequence
  String,       // LN char[N] (text up to the first NUL) or a constant -> ROS string
  StringArray,  // LN array of sub-types with a char[N] field -> ROS string array or sequence
  Time,         // LN seconds / nanoseconds -> builtin_interfaces Time/Duration
};

struct RuleMove {
  MoveKind kind = MoveKind::Number;
  std::string ros_path, ln_path;  // for messages
  // LN side (absent for constants)
  bool from_ln = false;
  std::size_t ln_offset = 0;
  md::Primitive ln_type = md::Primitive::Double;
  std::uint32_t ln_count = 1;  // elements (numbers, texts), or bytes of a String's char array
  std::size_t ln_stride = 0;   // bytes from one LN element to the next (0: packed numbers)
  std::uint32_t ln_text = 0;   // StringArray: bytes of each element's char array
  // ROS side: offsets in the fixed-size LN form of the ROS type
  std::size_t mid_offset = 0;         // the value / first element / text
  std::size_t mid_length_offset = 0;  // inline strings and sequences: their uint32 length
  md::Primitive mid_type = md::Primitive::Double;
  RosPrimitive ros_type = RosPrimitive::Float64;
  std::uint32_t mid_capacity = 0;  // inline string/sequence capacity, fixed array count
  std::uint32_t mid_text = 0;      // StringArray: capacity of each string
  std::size_t mid_stride = 0;      // StringArray: bytes from one string to the next
  bool sequence = false;
  bool nanoseconds = false;  // Time from integer nanoseconds
  bool scaled = false;
  long double scale = 1, offset = 0;
  long double constant_number = 0;
  std::string constant_text;
};

namespace {

std::string u(std::size_t v) { return std::to_string(v); }

std::string number_text(long double v) {
  char buffer[48];
  std::snprintf(buffer, sizeof buffer, "%.17Lg", v);
  return buffer;
}

long double read_number(const std::uint8_t* p, md::Primitive type) {
  switch (type) {
#define MM_READ(P, T)                   \
  case md::Primitive::P: {              \
    T v;                                \
    std::memcpy(&v, p, sizeof v);       \
    return static_cast<long double>(v); \
  }
    MM_READ(Float, float)
    MM_READ(Double, double)
    MM_READ(Char, char)
    MM_READ(Int8, std::int8_t)
    MM_READ(UInt8, std::uint8_t)
    MM_READ(Int16, std::int16_t)
    MM_READ(UInt16, std::uint16_t)
    MM_READ(Int32, std::int32_t)
    MM_READ(UInt32, std::uint32_t)
    MM_READ(Int64, std::int64_t)
    MM_READ(UInt64, std::uint64_t)
#undef MM_READ
  }
  return 0;
}

template <class T>
void store_integer(std::uint8_t* p, long double v, const std::string& where) {
  const long double r = std::nearbyint(v);
  if (!std::isfinite(r) || r < static_cast<long double>(std::numeric_limits<T>::min()) ||
      r > static_cast<long double>(std::numeric_limits<T>::max()))
    throw CodecError(where + ": value " + number_text(v) + " is out of range");
  const T t = static_cast<T>(r);
  std::memcpy(p, &t, sizeof t);
}

void write_number(std::uint8_t* p, md::Primitive type, long double v, const std::string& where) {
  switch (type) {
    case md::Primitive::Float: {
      const float f = static_cast<float>(v);
      std::memcpy(p, &f, 4);
      return;
    }
    case md::Primitive::Double: {
      const double d = static_cast<double>(v);
      std::memcpy(p, &d, 8);
      return;
    }
    case md::Primitive::Char:
      store_integer<char>(p, v, where);
      return;
    case md::Primitive::Int8:
      store_integer<std::int8_t>(p, v, where);
      return;
    case md::Primitive::UInt8:
      store_integer<std::uint8_t>(p, v, where);
      return;
    case md::Primitive::Int16:
      store_integer<std::int16_t>(p, v, where);
      return;
    case md::Primitive::UInt16:
      store_integer<std::uint16_t>(p, v, where);
      return;
    case md::Primitive::Int32:
      store_integer<std::int32_t>(p, v, where);
      return;
    case md::Primitive::UInt32:
      store_integer<std::uint32_t>(p, v, where);
      return;
    case md::Primitive::Int64:
      store_integer<std::int64_t>(p, v, where);
      return;
    case md::Primitive::UInt64:
      store_integer<std::uint64_t>(p, v, where);
      return;
  }
}

int integer_bits(md::Primitive t) { return md::is_integer(t) ? static_cast<int>(md::size_of(t) * 8) : 0; }

// Can every value of `from` be represented exactly in `to`?
bool is_lossless(md::Primitive from, md::Primitive to) {
  if (from == to) return true;
  const bool from_float = md::is_floating_point(from), to_float = md::is_floating_point(to);
  if (from_float) return to_float && md::size_of(to) > md::size_of(from);
  const int bits = integer_bits(from) - (md::is_signed(from) ? 1 : 0);  // magnitude bits
  if (to_float) return bits <= (to == md::Primitive::Float ? 24 : 53);
  if (md::is_signed(from) && !md::is_signed(to)) return false;
  return bits <= integer_bits(to) - (md::is_signed(to) ? 1 : 0);
}

std::string type_name(md::Primitive t) { return std::string(md::c_name(t)); }

bool parse_number(const std::string& text, long double& value) {
  const std::string s(text::strip(text));
  if (s.empty()) return false;
  char* end = nullptr;
  value = std::strtold(s.c_str(), &end);
  return end == s.c_str() + s.size() && std::isfinite(value);
}

struct PathPart {
  std::string name;
  bool indexed = false;
  std::uint32_t index = 0;
};

std::vector<PathPart> parse_path(const std::string& path, const std::string& where) {
  std::vector<PathPart> parts;
  std::size_t start = 0;
  for (;;) {
    const auto dot = path.find('.', start);
    std::string part =
        std::string(text::strip(path.substr(start, dot == std::string::npos ? std::string::npos : dot - start)));
    PathPart p;
    if (const auto bracket = part.find('['); bracket != std::string::npos) {
      if (part.back() != ']') throw Error(where + ": '" + path + "' has an unbalanced '['");
      const std::string digits = part.substr(bracket + 1, part.size() - bracket - 2);
      char* end = nullptr;
      const unsigned long v = std::strtoul(digits.c_str(), &end, 10);
      if (digits.empty() || end != digits.c_str() + digits.size() || v > 0xffffffffUL)
        throw Error(where + ": '" + path + "': index '" + digits + "' is not a non-negative integer");
      p.indexed = true;
      p.index = static_cast<std::uint32_t>(v);
      part = part.substr(0, bracket);
    }
    if (part.empty()) throw Error(where + ": '" + path + "' is not a field path");
    p.name = part;
    parts.push_back(p);
    if (dot == std::string::npos) break;
    start = dot + 1;
  }
  return parts;
}

std::string join_ln_path(const std::vector<PathPart>& parts) {
  std::string out;
  for (const auto& p : parts) {
    if (!out.empty()) out += ".";
    out += p.name;
    if (p.indexed) out += "[" + u(p.index) + "]";
  }
  return out;
}

// The ROS leaf a rule targets, resolved in the fixed-size LN form of the ROS type.
struct RosTarget {
  const PairedField* field = nullptr;  // the last field on the path
  bool element = false;                // "a[2]": one element of a fixed array
  std::string mid_path;                // LN path in the ROS type's LN form
};

RosTarget resolve_ros(const PairedType& root, const std::string& path, const std::string& where) {
  RosTarget target;
  const PairedType* type = &root;
  std::vector<PathPart> parts = parse_path(path, where);
  std::vector<PathPart> ln_parts;
  for (std::size_t i = 0; i < parts.size(); ++i) {
    const PathPart& part = parts[i];
    if (!type) throw Error(where + ": ROS field '" + path + "': '" + parts[i - 1].name + "' has no fields");
    const PairedField* found = nullptr;
    std::string names;
    for (const auto& f : type->fields) {
      names += (names.empty() ? "" : ", ") + f.ros_name;
      if (f.ros_name == part.name) found = &f;
    }
    if (!found)
      throw Error(where + ": ROS field '" + path + "' does not exist ('" + part.name + "' is not a field of " +
                  type->ros_name + ", which has: " + names + ")");
    if (part.indexed && (found->shape != Shape::FixedArray || part.index >= found->count))
      throw Error(where + ": ROS field '" + path + "': " +
                  (found->shape != Shape::FixedArray
                       ? "only fixed-size arrays can be indexed"
                       : "index " + u(part.index) + " is out of range (" + u(found->count) + " elements)"));
    ln_parts.push_back({found->ln_name, part.indexed, part.index});
    target.field = found;
    target.element = part.indexed;
    const bool last = i + 1 == parts.size();
    if (!last) {
      if (found->element != ElementKind::Struct || (found->shape != Shape::Single && !part.indexed))
        throw Error(where + ": ROS field '" + path + "': '" + part.name + "' is not a message (or needs an index)");
      type = found->struct_type;
    }
  }
  target.mid_path = join_ln_path(ln_parts);
  return target;
}

// The LN field a rule reads. "joints.position", with `joints` an array of a
// sub-type, reads that field of every element: `repeat` elements `stride`
// bytes apart, the first at `first_path` ("joints[0].position").
struct LnSource {
  const md::Field* field = nullptr;
  bool element = false;
  std::uint32_t repeat = 1;
  std::size_t stride = 0;
  std::string first_path;
};

LnSource resolve_ln(const md::Definition& root, const std::string& path, const std::string& where) {
  LnSource source;
  const md::Definition* def = &root;
  std::vector<PathPart> parts = parse_path(path, where);
  for (std::size_t i = 0; i < parts.size(); ++i) {
    const md::Field* found = nullptr;
    std::string names;
    for (const auto& f : def->fields) {
      names += (names.empty() ? "" : ", ") + f.name;
      if (f.name == parts[i].name) found = &f;
    }
    if (!found)
      throw Error(where + ": LN field '" + path + "' does not exist in '" + def->name + "' (fields: " + names + ")");
    if (parts[i].indexed && parts[i].index >= found->count)
      throw Error(where + ": LN field '" + path + "': index " + u(parts[i].index) + " is out of range (" +
                  u(found->count) + " element(s))");
    source.field = found;
    source.element = parts[i].indexed || found->count == 1;
    if (i + 1 < parts.size()) {
      if (!found->sub) throw Error(where + ": LN field '" + path + "': '" + found->name + "' has no fields");
      if (!parts[i].indexed && found->count > 1) {  // one value per element of this array
        if (source.repeat > 1)
          throw Error(where + ": LN field '" + path + "' runs over two arrays; give one of them an index");
        source.repeat = found->count;
        source.stride = md::packet_size(*found->sub);
        parts[i].indexed = true;
        parts[i].index = 0;
      }
      def = found->sub;
    }
  }
  source.first_path = join_ln_path(parts);
  return source;
}

}  // namespace

RuleCodec::RuleCodec(const md::Definition& ln, RosToLn& ros, const std::string& ros_type,
                     const std::vector<FieldRule>& rules)
    : ln_name_(ln.name) {
  const std::string where_type = "rule " + ln.name + " -> " + ros_type;
  if (ln.kind != md::Kind::Plain || ln.is_dynamic())
    throw Error(where_type + ": rules need a plain LN definition without dynamic fields (a topic packet)");
  std::string package, kind, type;
  split_ros_type_name(ros_type, package, kind, type);
  if (kind == "srv") throw Error(where_type + ": rules map onto ROS messages, not services");
  const PairedInterface& mid = ros.add(ros_type, false);  // throws "unknown ROS message type"
  ros_name_ = mid.ros_name;
  mid_codec_ = std::make_unique<Codec>(*mid.first);
  mid_size_ = mid_codec_->fixed_ln_size();
  if (mid_size_ == 0) throw Error(where_type + ": internal error: the LN form of the ROS type is not fixed-size");
  ln_size_ = md::packet_size(ln);
  const md::Definition& mid_def = ros.library().load(mid.ln_name);

  std::set<std::string> targets;
  for (const FieldRule& rule : rules) {
    const std::string where = where_type + ", ROS field '" + rule.ros_path + "'";
    const RosTarget target = resolve_ros(*mid.first, rule.ros_path, where_type);
    for (const auto& t : targets)
      if (t == rule.ros_path || text::starts_with(t, rule.ros_path + ".") || text::starts_with(rule.ros_path, t + "."))
        throw Error(where + ": overlaps the rule for '" + t + "'");
    targets.insert(rule.ros_path);
    if (rule.has_constant == !rule.ln_path.empty())
      throw Error(where + ": give exactly one of 'from' (an LN field) and 'value' (a constant)");

    RuleMove m;
    m.ros_path = rule.ros_path;
    m.ln_path = rule.ln_path;
    const PairedField& f = *target.field;
    m.mid_offset = md::locate_member(mid_def, target.mid_path).offset;

    LnSource source;
    if (!rule.ln_path.empty()) {
      source = resolve_ln(ln, rule.ln_path, where_type);
      if (source.field->sub)
        throw Error(where + ": LN field '" + rule.ln_path + "' is a " + source.field->sub->name +
                    "; map its fields one by one");
      m.from_ln = true;
      m.ln_offset = md::locate_member(ln, source.first_path).offset;
      m.ln_type = *source.field->primitive;
      m.ln_count = source.element ? 1 : source.field->count;
    }
    const bool whole_array = !target.element && f.shape != Shape::Single;
    if (source.repeat > 1 && !whole_array)
      throw Error(where + ": LN field '" + rule.ln_path +
                  "' has one value per element of an LN array: it fits a ROS "
                  "array, not " +
                  f.ros_type().spelling());
    if (source.repeat > 1 && f.element != ElementKind::String && m.ln_count != 1)
      throw Error(where + ": LN field '" + rule.ln_path + "' is " + type_name(m.ln_type) + "[" + u(m.ln_count) +
                  "] per element; " + f.ros_type().spelling() + " takes one number per element");
    if (!rule.scale.empty() || !rule.offset.empty()) {
      m.scaled = true;
      if (!rule.scale.empty() && !parse_number(rule.scale, m.scale))
        throw Error(where + ": scale '" + rule.scale + "' is not a number");
      if (!rule.offset.empty() && !parse_number(rule.offset, m.offset))
        throw Error(where + ": offset '" + rule.offset + "' is not a number");
      if (m.scale == 0) throw Error(where + ": scale 0 cannot be inverted");
      if (rule.has_constant) throw Error(where + ": scale/offset make no sense with a constant");
    }

    if (!rule.convert.empty()) {
      if (rule.convert != "seconds_to_time" && rule.convert != "nanoseconds_to_time")
        throw Error(where + ": unknown convert '" + rule.convert + "' (seconds_to_time, nanoseconds_to_time)");
      const std::string nested = f.struct_type ? f.struct_type->ros_name : "";
      if (f.element != ElementKind::Struct || target.element || f.shape != Shape::Single ||
          (nested != "builtin_interfaces/msg/Time" && nested != "builtin_interfaces/msg/Duration"))
        throw Error(where + ": convert " + rule.convert + " needs a builtin_interfaces/Time or Duration field, not " +
                    f.ros_type().spelling());
      if (!m.from_ln || m.ln_count != 1)
        throw Error(where + ": convert " + rule.convert + " needs one LN number ('from')");
      m.kind = MoveKind::Time;
      m.nanoseconds = rule.convert == "nanoseconds_to_time";
      if (m.nanoseconds && !md::is_integer(m.ln_type))
        throw Error(where + ": nanoseconds_to_time needs an LN integer, '" + rule.ln_path + "' is " +
                    type_name(m.ln_type));
      if (m.scaled) throw Error(where + ": scale/offset cannot be combined with convert");
      moves_.push_back(m);
      continue;
    }

    if (f.element == ElementKind::Struct)
      throw Error(where + ": it is a " + f.ros_type().spelling() + " message; map its fields one by one" +
                  " (or use convert for Time/Duration)");

    if (f.element == ElementKind::String && whole_array) {
      if (source.repeat == 1)
        throw Error(where +
                    ": an array of strings takes one LN char array per element: 'from: names.text' with "
                    "'names' an LN array of a definition that has a char array 'text'");
      if (m.ln_type != md::Primitive::Char && m.ln_type != md::Primitive::UInt8 && m.ln_type != md::Primitive::Int8)
        throw Error(where + ": a string needs an LN char array, '" + rule.ln_path + "' is " + type_name(m.ln_type));
      if (m.scaled) throw Error(where + ": scale/offset on strings");
      m.kind = MoveKind::StringArray;
      m.sequence = f.shape == Shape::InlineSequence;
      m.ln_text = m.ln_count;
      m.ln_count = source.repeat;
      m.ln_stride = source.stride;
      m.mid_capacity = f.count;
      m.mid_text = f.string_capacity;
      m.mid_stride = 4 + std::size_t{f.string_capacity};  // the helper type: uint32_t data_len; char data[cap]
      m.mid_length_offset = m.sequence ? md::locate_member(mid_def, target.mid_path + "_len").offset : 0;
      m.mid_offset = md::locate_member(mid_def, target.mid_path + "[0].data_len").offset;
      if (!m.sequence && m.ln_count != f.count)
        throw Error(where + ": " + f.ros_type().spelling() + " has " + u(f.count) + " strings, LN array has " +
                    u(m.ln_count));
      if (m.sequence && (m.ln_count > f.count || (f.ros_bound && m.ln_count > f.ros_bound)))
        throw Error(where + ": the LN array has " + u(m.ln_count) + " elements, more than the sequence can hold (" +
                    u(f.ros_bound && f.ros_bound < f.count ? f.ros_bound : f.count) + ")");
      moves_.push_back(m);
      continue;
    }

    if (f.element == ElementKind::String) {
      m.kind = MoveKind::String;
      m.mid_capacity = f.string_capacity;
      const std::string text_path = target.element ? target.mid_path + ".data" : target.mid_path;  // "a[1]": a helper
      m.mid_offset = md::locate_member(mid_def, text_path).offset;
      m.mid_length_offset = md::locate_member(mid_def, text_path + "_len").offset;
      if (rule.has_constant) {
        m.constant_text = rule.constant;
        if (m.constant_text.size() > f.string_capacity)
          throw Error(where + ": the constant has " + u(m.constant_text.size()) + " bytes, more than the capacity " +
                      u(f.string_capacity));
      } else if (m.ln_type != md::Primitive::Char && m.ln_type != md::Primitive::UInt8 &&
                 m.ln_type != md::Primitive::Int8) {
        throw Error(where + ": a string needs an LN char array, '" + rule.ln_path + "' is " + type_name(m.ln_type));
      } else if (m.ln_count == 1 && source.field->count != 1) {
        throw Error(where + ": a string needs a whole LN char array, not one element");
      }
      if (m.scaled) throw Error(where + ": scale/offset on a string");
      moves_.push_back(m);
      continue;
    }

    // Numbers.
    m.ros_type = f.ros_primitive;
    m.mid_type = f.ln_primitive;
    if (whole_array) {
      m.kind = MoveKind::Array;
      if (source.repeat > 1) {  // one number per element of an LN array of sub-types
        m.ln_count = source.repeat;
        m.ln_stride = source.stride;
      }
      m.sequence = f.shape == Shape::InlineSequence;
      m.mid_capacity = f.count;
      if (m.sequence) m.mid_length_offset = md::locate_member(mid_def, target.mid_path + "_len").offset;
      if (rule.has_constant) throw Error(where + ": an array cannot be set to a constant");
      if (m.ln_count == 1)
        throw Error(where + ": it is an array (" + f.ros_type().spelling() + "), but LN field '" + rule.ln_path +
                    "' is a single " + type_name(m.ln_type));
      if (!m.sequence && m.ln_count != f.count)
        throw Error(where + ": " + f.ros_type().spelling() + " has " + u(f.count) + " elements, LN field '" +
                    rule.ln_path + "' has " + u(m.ln_count));
      if (m.sequence && (m.ln_count > f.count || (f.ros_bound && m.ln_count > f.ros_bound)))
        throw Error(where + ": LN field '" + rule.ln_path + "' has " + u(m.ln_count) +
                    " elements, more than the sequence can hold (" + u(f.count) + ")");
    } else {
      m.kind = MoveKind::Number;
      if (m.from_ln && m.ln_count != 1)
        throw Error(where + ": it is a single " + std::string(spelling(f.ros_primitive)) + ", but LN field '" +
                    rule.ln_path + "' is an array of " + u(m.ln_count) + "; pick an element like '" + rule.ln_path +
                    "[0]'");
    }
    if (rule.has_constant) {
      if (!parse_number(rule.constant, m.constant_number))
        throw Error(where + ": constant '" + rule.constant + "' is not a number");
      if (md::is_integer(m.mid_type) && std::nearbyint(m.constant_number) != m.constant_number)
        throw Error(where + ": constant '" + rule.constant + "' is not an integer");
      try {
        std::uint8_t scratch[8];
        write_number(scratch, m.mid_type, m.constant_number, where);
      } catch (const CodecError&) {
        throw Error(where + ": constant '" + rule.constant + "' is out of range for " +
                    std::string(spelling(f.ros_primitive)));
      }
    } else if (m.ros_type != RosPrimitive::Bool) {
      const bool lossless = m.scaled ? md::is_floating_point(m.mid_type) : is_lossless(m.ln_type, m.mid_type);
      if (!lossless && !rule.lossy)
        throw Error(where + ": LN field '" + rule.ln_path + "' (" + type_name(m.ln_type) + ") does not fit ROS " +
                    std::string(spelling(f.ros_primitive)) + (m.scaled ? " once scaled" : "") +
                    " without loss; add 'lossy: true' to accept rounding/narrowing");
    } else if (!md::is_integer(m.ln_type)) {
      throw Error(where + ": a ROS bool needs an LN integer, '" + rule.ln_path + "' is " + type_name(m.ln_type));
    }
    moves_.push_back(m);
  }
}

RuleCodec::~RuleCodec() = default;
RuleCodec::RuleCodec(RuleCodec&&) noexcept = default;
RuleCodec& RuleCodec::operator=(RuleCodec&&) noexcept = default;

namespace {

std::size_t ln_step(const RuleMove& m) { return m.ln_stride ? m.ln_stride : md::size_of(m.ln_type); }

void encode_number(const RuleMove& m, const std::uint8_t* ln, std::uint8_t* mid, std::size_t index) {
  const std::uint8_t* src = ln + m.ln_offset + index * ln_step(m);
  std::uint8_t* dst = mid + m.mid_offset + index * md::size_of(m.mid_type);
  if (m.ros_type == RosPrimitive::Bool) {
    *dst = read_number(src, m.ln_type) != 0;
    return;
  }
  if (!m.scaled && m.ln_type == m.mid_type) {
    std::memcpy(dst, src, md::size_of(m.ln_type));
    return;
  }
  long double v = read_number(src, m.ln_type);
  if (m.scaled) v = v * m.scale + m.offset;
  write_number(dst, m.mid_type, v, m.ros_path);
}

void decode_number(const RuleMove& m, const std::uint8_t* mid, std::uint8_t* ln, std::size_t index) {
  const std::uint8_t* src = mid + m.mid_offset + index * md::size_of(m.mid_type);
  std::uint8_t* dst = ln + m.ln_offset + index * ln_step(m);
  if (!m.scaled && m.ln_type == m.mid_type) {
    std::memcpy(dst, src, md::size_of(m.ln_type));
    return;
  }
  long double v = read_number(src, m.mid_type);
  if (m.scaled) v = (v - m.offset) / m.scale;
  write_number(dst, m.ln_type, v, m.ln_path);
}

std::uint32_t read_u32(const std::uint8_t* p) {
  std::uint32_t v;
  std::memcpy(&v, p, 4);
  return v;
}
void write_u32(std::uint8_t* p, std::uint32_t v) { std::memcpy(p, &v, 4); }

constexpr long double ns_per_s = 1e9L;

}  // namespace

std::vector<std::uint8_t> RuleCodec::ln_to_cdr(Bytes ln) const {
  if (ln.size != ln_size_)
    throw CodecError(ln_name_ + ": LN message of " + u(ln.size) + " bytes, expected " + u(ln_size_));
  std::vector<std::uint8_t> mid(mid_size_, 0);
  for (const RuleMove& m : moves_) {
    switch (m.kind) {
      case MoveKind::Number:
        if (m.from_ln)
          encode_number(m, ln.data, mid.data(), 0);
        else
          write_number(mid.data() + m.mid_offset, m.mid_type, m.constant_number, m.ros_path);
        break;
      case MoveKind::Array:
        if (m.sequence) write_u32(mid.data() + m.mid_length_offset, m.ln_count);
        for (std::uint32_t i = 0; i < m.ln_count; ++i) encode_number(m, ln.data, mid.data(), i);
        break;
      case MoveKind::String: {
        const std::uint8_t* text =
            m.from_ln ? ln.data + m.ln_offset : reinterpret_cast<const std::uint8_t*>(m.constant_text.data());
        const std::size_t n =
            m.from_ln ? strnlen(reinterpret_cast<const char*>(text), m.ln_count) : m.constant_text.size();
        if (n > m.mid_capacity)
          throw CodecError(ros_name_ + "." + m.ros_path + ": text of " + u(n) + " bytes exceeds the capacity " +
                           u(m.mid_capacity));
        write_u32(mid.data() + m.mid_length_offset, static_cast<std::uint32_t>(n));
        std::memcpy(mid.data() + m.mid_offset, text, n);
        break;
      }
      case MoveKind::StringArray: {
        if (m.sequence) write_u32(mid.data() + m.mid_length_offset, m.ln_count);
        for (std::uint32_t i = 0; i < m.ln_count; ++i) {
          const char* text = reinterpret_cast<const char*>(ln.data + m.ln_offset + i * m.ln_stride);
          const std::size_t n = strnlen(text, m.ln_text);
          if (n > m.mid_text)
            throw CodecError(ros_name_ + "." + m.ros_path + "[" + u(i) + "]: text of " + u(n) +
                             " bytes exceeds the capacity " + u(m.mid_text));
          std::uint8_t* element = mid.data() + m.mid_offset + i * m.mid_stride;
          write_u32(element, static_cast<std::uint32_t>(n));
          std::memcpy(element + 4, text, n);
        }
        break;
      }
      case MoveKind::Time: {
        const long double v = read_number(ln.data + m.ln_offset, m.ln_type);
        const long double total_ns = m.nanoseconds ? v : std::nearbyint(v * ns_per_s);
        const long double sec = std::floor(total_ns / ns_per_s);
        const long double nsec = total_ns - sec * ns_per_s;
        write_number(mid.data() + m.mid_offset, md::Primitive::Int32, sec, ros_name_ + "." + m.ros_path + ".sec");
        write_number(mid.data() + m.mid_offset + 4, md::Primitive::UInt32, nsec,
                     ros_name_ + "." + m.ros_path + ".nanosec");
        break;
      }
    }
  }
  return mid_codec_->ln_to_cdr(Bytes{mid.data(), mid.size()});
}

std::vector<std::uint8_t> RuleCodec::cdr_to_ln(Bytes cdr) const {
  const std::vector<std::uint8_t> mid = mid_codec_->cdr_to_ln(cdr);
  std::vector<std::uint8_t> ln(ln_size_, 0);
  for (const RuleMove& m : moves_) {
    if (!m.from_ln) continue;  // constants do not travel back
    switch (m.kind) {
      case MoveKind::Number:
        decode_number(m, mid.data(), ln.data(), 0);
        break;
      case MoveKind::Array: {
        const std::uint32_t n = m.sequence ? read_u32(mid.data() + m.mid_length_offset) : m.ln_count;
        if (n > m.ln_count)
          throw CodecError(ros_name_ + "." + m.ros_path + ": " + u(n) + " elements do not fit LN field '" + m.ln_path +
                           "' (" + u(m.ln_count) + ")");
        for (std::uint32_t i = 0; i < n; ++i) decode_number(m, mid.data(), ln.data(), i);
        break;
      }
      case MoveKind::String: {
        const std::uint32_t n = read_u32(mid.data() + m.mid_length_offset);
        if (n > m.ln_count)
          throw CodecError(ros_name_ + "." + m.ros_path + ": a string of " + u(n) + " bytes does not fit LN field '" +
                           m.ln_path + "' (" + u(m.ln_count) + " bytes)");
        std::memcpy(ln.data() + m.ln_offset, mid.data() + m.mid_offset, n);
        break;
      }
      case MoveKind::StringArray: {
        const std::uint32_t n = m.sequence ? read_u32(mid.data() + m.mid_length_offset) : m.ln_count;
        if (n > m.ln_count)
          throw CodecError(ros_name_ + "." + m.ros_path + ": " + u(n) + " strings do not fit LN field '" + m.ln_path +
                           "' (" + u(m.ln_count) + ")");
        for (std::uint32_t i = 0; i < n; ++i) {
          const std::uint8_t* element = mid.data() + m.mid_offset + i * m.mid_stride;
          const std::uint32_t length = read_u32(element);
          if (length > m.ln_text)
            throw CodecError(ros_name_ + "." + m.ros_path + "[" + u(i) + "]: a string of " + u(length) +
                             " bytes does not fit LN field '" + m.ln_path + "' (" + u(m.ln_text) + " bytes)");
          std::memcpy(ln.data() + m.ln_offset + i * m.ln_stride, element + 4, length);
        }
        break;
      }
      case MoveKind::Time: {
        const long double sec = read_number(mid.data() + m.mid_offset, md::Primitive::Int32);
        const long double nsec = read_number(mid.data() + m.mid_offset + 4, md::Primitive::UInt32);
        const long double total_ns = sec * ns_per_s + nsec;
        write_number(ln.data() + m.ln_offset, m.ln_type, m.nanoseconds ? total_ns : total_ns / ns_per_s, m.ln_path);
        break;
      }
    }
  }
  return ln;
}

std::string RuleCodec::describe() const {
  std::string out = ln_name_ + " -> " + ros_name_ + "\n";
  for (const RuleMove& m : moves_) {
    out += "  " + m.ros_path + " <- ";
    out += m.from_ln ? m.ln_path
                     : "constant " + (m.kind == MoveKind::String ? "\"" + m.constant_text + "\""
                                                                 : number_text(m.constant_number));
    if (m.scaled) out += " * " + number_text(m.scale) + " + " + number_text(m.offset);
    if (m.kind == MoveKind::Time) out += m.nanoseconds ? " (nanoseconds)" : " (seconds)";
    out += "\n";
  }
  return out;
}

}  // namespace msg_mapping
