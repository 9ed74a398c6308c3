#include "msg_mapping/ros_model.hpp"

#include <sys/stat.h>

#include <dirent.h>
#include <algorithm>
#include <charconv>
#include <fstream>
#include <sstream>

#include "msg_mapping/naming.hpp"
#include "text_util.hpp"

namespace msg_mapping {
namespace {

struct PrimitiveInfo {
  RosPrimitive type;
  std::string_view spelling;
  std::size_t size;
};

constexpr PrimitiveInfo primitives[] = {
    {RosPrimitive::Bool, "bool", 1},       {RosPrimitive::Byte, "byte", 1},       {RosPrimitive::Char, "char", 1},
    {RosPrimitive::Float32, "float32", 4}, {RosPrimitive::Float64, "float64", 8}, {RosPrimitive::Int8, "int8", 1},
    {RosPrimitive::UInt8, "uint8", 1},     {RosPrimitive::Int16, "int16", 2},     {RosPrimitive::UInt16, "uint16", 2},
    {RosPrimitive::Int32, "int32", 4},     {RosPrimitive::UInt32, "uint32", 4},   {RosPrimitive::Int64, "int64", 8},
    {RosPrimitive::UInt64, "uint64", 8},   {RosPrimitive::String, "string", 0},   {RosPrimitive::WString, "wstring", 0},
};

std::uint32_t parse_positive(std::string_view digits, const std::string& what) {
  std::uint32_t value = 0;
  const auto [end, error] = std::from_chars(digits.data(), digits.data() + digits.size(), value);
  if (error != std::errc() || end != digits.data() + digits.size() || value == 0)
    throw Error(what + ": '" + std::string(digits) + "' is not an integer > 0");
  return value;
}

RosFieldType parse_type(std::string_view spelling, std::string_view package, const std::string& where) {
  RosFieldType type;
  std::string_view element = spelling;
  if (!element.empty() && element.back() == ']') {
    const auto open = element.rfind('[');
    if (open == std::string_view::npos) throw Error(where + ": type '" + std::string(spelling) + "' lacks '['");
    std::string_view size = element.substr(open + 1, element.size() - open - 2);
    element = element.substr(0, open);
    if (size.empty()) {
      type.array = RosFieldType::Array::Unbounded;
    } else if (text::starts_with(size, "<=")) {
      type.array = RosFieldType::Array::Bounded;
      type.array_size = parse_positive(size.substr(2), where + ": array bound of '" + std::string(spelling) + "'");
    } else {
      type.array = RosFieldType::Array::Fixed;
      type.array_size = parse_positive(size, where + ": array size of '" + std::string(spelling) + "'");
    }
  }
  for (std::string_view s : {std::string_view("string<="), std::string_view("wstring<=")}) {
    if (text::starts_with(element, s)) {
      type.primitive = s[0] == 'w' ? RosPrimitive::WString : RosPrimitive::String;
      type.string_bound =
          parse_positive(element.substr(s.size()), where + ": string bound of '" + std::string(spelling) + "'");
      return type;
    }
  }
  if (auto primitive = ros_primitive_from_spelling(element)) {
    type.primitive = primitive;
    return type;
  }
  if (element == "time" || element == "duration")
    throw Error(where + ": '" + std::string(element) +
                "' is a ROS 1 type; use builtin_interfaces/Time or builtin_interfaces/Duration");
  std::string pkg(package), name(element);
  if (const auto slash = element.find('/'); slash != std::string_view::npos) {
    pkg = std::string(element.substr(0, slash));
    name = std::string(element.substr(slash + 1));
    if (name.rfind("msg/", 0) == 0) name = name.substr(4);  // "pkg/msg/Type" (IDL style) is accepted too
  }
  if (!is_valid_ros_package_name(pkg) || !is_valid_ros_type_name(name))
    throw Error(where + ": '" + std::string(element) + "' is neither a primitive type nor 'package/Type'");
  type.nested = pkg + "/" + name;
  return type;
}

std::string read_text_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error("cannot read '" + path + "'");
  std::ostringstream content;
  content << in.rdbuf();
  return content.str();
}

bool is_regular_file(const std::string& path) {
  struct stat st;
  return ::stat(path.c_str(), &st) == 0 && S_ISREG(st.st_mode);
}

// One .msg body (a message or one half of a service).
class MsgParser {
 public:
  MsgParser(RosMessage& message, std::string where) : msg_(message), where_(std::move(where)) {}

  void parse(const std::vector<std::string>& lines, int first_line_number) {
    // File-level comments: the leading run of lines that start with '#'.
    std::size_t i = 0;
    while (i < lines.size() && !lines[i].empty() && lines[i][0] == '#') {
      msg_.comments.push_back(std::string(text::strip(std::string_view(lines[i]).substr(1), " ")));
      ++i;
    }
    std::vector<std::string> pending_comments;
    for (; i < lines.size(); ++i) {
      line_number_ = first_line_number + static_cast<int>(i);
      std::string_view line = text::rstrip(lines[i]);
      if (line.empty()) continue;
      std::string_view comment;
      bool has_comment = false;
      if (const auto hash = line.find('#'); hash != std::string_view::npos) {
        comment = text::strip(line.substr(hash + 1), " ");
        has_comment = true;
        line = line.substr(0, hash);
      }
      if (has_comment) {
        if (!line.empty() && text::strip(line).empty()) {  // indented comment: belongs to the element above
          if (!msg_.fields.empty()) msg_.fields.back().comments.emplace_back(comment);
          continue;
        }
        line = text::rstrip(line);
        if (line.empty()) {
          pending_comments.emplace_back(comment);
          continue;
        }
      }
      const auto blank = line.find(' ');
      if (blank == std::string_view::npos) fail("expected 'TYPE NAME', got '" + std::string(line) + "'");
      const std::string_view type_word = line.substr(0, blank);
      const std::string_view rest = text::strip(line.substr(blank), " ");
      if (rest.empty()) fail("expected 'TYPE NAME', got '" + std::string(line) + "'");
      if (const auto equals = rest.find('='); equals != std::string_view::npos) {
        RosConstant constant;
        constant.type = std::string(type_word);
        constant.name = std::string(text::rstrip(rest.substr(0, equals)));
        constant.value = std::string(text::strip(rest.substr(equals + 1), " "));
        if (!is_valid_ros_constant_name(constant.name)) fail("'" + constant.name + "' is not a valid constant name");
        msg_.constants.push_back(std::move(constant));
        pending_comments.clear();
        continue;
      }
      RosField field;
      const auto name_end = rest.find(' ');
      field.name = std::string(rest.substr(0, name_end));
      if (name_end != std::string_view::npos)
        field.default_value = std::string(text::strip(rest.substr(name_end), " "));
      field.type = parse_type(type_word, msg_.package, location());
      if (!is_valid_ros_field_name(field.name)) fail("'" + field.name + "' is not a valid field name");
      for (const auto& other : msg_.fields)
        if (other.name == field.name) fail("field '" + field.name + "' is declared twice");
      field.comments = std::move(pending_comments);
      if (has_comment) field.comments.emplace_back(comment);
      pending_comments.clear();
      msg_.fields.push_back(std::move(field));
    }
  }

 private:
  std::string location() const { return where_ + ":" + std::to_string(line_number_); }
  [[noreturn]] void fail(const std::string& message) const { throw Error(location() + ": " + message); }

  RosMessage& msg_;
  std::string where_;
  int line_number_ = 0;
};

std::vector<std::string> split_lines(std::string_view text) {
  std::vector<std::string> lines;
  std::string current;
  for (char c : text) {
    if (c == '\n') {
      lines.push_back(std::move(current));
      current.clear();
    } else if (c == '\t') {
      current += ' ';
    } else if (c != '\r') {
      current += c;
    }
  }
  if (!current.empty()) lines.push_back(std::move(current));
  return lines;
}

void emit_comment_lines(std::string& out, const std::vector<std::string>& comments) {
  for (const auto& c : comments) out += c.empty() ? "#\n" : "# " + c + "\n";
}

void emit_body(std::string& out, const RosMessage& message) {
  for (const auto& c : message.constants) out += c.type + " " + c.name + "=" + c.value + "\n";
  for (const auto& f : message.fields) {
    emit_comment_lines(out, f.comments);
    out += f.type.spelling() + " " + f.name;
    if (!f.default_value.empty()) out += " " + f.default_value;
    out += "\n";
  }
}

}  // namespace

std::string_view spelling(RosPrimitive type) {
  for (const auto& p : primitives)
    if (p.type == type) return p.spelling;
  return "?";
}

std::optional<RosPrimitive> ros_primitive_from_spelling(std::string_view s) {
  for (const auto& p : primitives)
    if (p.spelling == s) return p.type;
  return std::nullopt;
}

std::size_t cdr_size(RosPrimitive type) {
  for (const auto& p : primitives)
    if (p.type == type) return p.size;
  return 0;
}

bool is_string(RosPrimitive type) { return type == RosPrimitive::String || type == RosPrimitive::WString; }

std::string RosFieldType::element_spelling() const {
  if (!primitive) return nested;
  std::string s(msg_mapping::spelling(*primitive));
  if (string_bound) s += "<=" + std::to_string(string_bound);
  return s;
}

std::string RosFieldType::spelling() const {
  std::string s = element_spelling();
  switch (array) {
    case Array::None:
      break;
    case Array::Fixed:
      s += "[" + std::to_string(array_size) + "]";
      break;
    case Array::Bounded:
      s += "[<=" + std::to_string(array_size) + "]";
      break;
    case Array::Unbounded:
      s += "[]";
      break;
  }
  return s;
}

std::string RosMessage::full_name() const { return package + (is_service_part ? "/srv/" : "/msg/") + name; }

RosMessage parse_msg(std::string_view package, std::string_view name, std::string_view text) {
  RosMessage message;
  message.package = std::string(package);
  message.name = std::string(name);
  MsgParser(message, message.package + "/msg/" + message.name).parse(split_lines(text), 1);
  return message;
}

RosService parse_srv(std::string_view package, std::string_view name, std::string_view text) {
  RosService service;
  service.package = std::string(package);
  service.name = std::string(name);
  const auto lines = split_lines(text);
  const auto separator =
      std::find_if(lines.begin(), lines.end(), [](const std::string& l) { return text::strip(l) == "---"; });
  const std::string where = service.full_name();
  if (separator == lines.end()) throw Error(where + ": no '---' line between request and response");
  for (auto* part : {&service.request, &service.response}) {
    part->package = service.package;
    part->is_service_part = true;
  }
  service.request.name = service.name + "_Request";
  service.response.name = service.name + "_Response";
  MsgParser(service.request, where).parse({lines.begin(), separator}, 1);
  MsgParser(service.response, where)
      .parse({separator + 1, lines.end()}, static_cast<int>(separator - lines.begin()) + 2);
  service.comments = std::move(service.request.comments);
  service.request.comments.clear();
  return service;
}

std::string emit_msg(const RosMessage& message) {
  std::string out;
  emit_comment_lines(out, message.comments);
  if (!message.comments.empty()) out += "\n";
  emit_body(out, message);
  return out;
}

std::string emit_srv(const RosService& service) {
  std::string out;
  emit_comment_lines(out, service.comments);
  if (!service.comments.empty()) out += "\n";
  emit_body(out, service.request);
  out += "---\n";
  emit_body(out, service.response);
  return out;
}

void split_ros_type_name(std::string_view full, std::string& package, std::string& kind, std::string& type) {
  std::vector<std::string_view> parts;
  std::size_t start = 0;
  for (;;) {
    const auto slash = full.find('/', start);
    parts.push_back(full.substr(start, slash == std::string_view::npos ? std::string_view::npos : slash - start));
    if (slash == std::string_view::npos) break;
    start = slash + 1;
  }
  if (parts.size() == 3 && (parts[1] == "msg" || parts[1] == "srv")) {
    kind = std::string(parts[1]);
  } else if (parts.size() == 2) {
    kind.clear();
  } else {
    throw Error("'" + std::string(full) + "' is not a ROS type name ('pkg/msg/Type', 'pkg/srv/Type' or 'pkg/Type')");
  }
  package = std::string(parts.front());
  type = std::string(parts.back());
  if (!is_valid_ros_package_name(package) || !is_valid_ros_type_name(type))
    throw Error("'" + std::string(full) + "' is not a valid ROS type name");
}

RosTypeStore::RosTypeStore(std::vector<std::string> share_dirs) : share_dirs_(std::move(share_dirs)) {}

std::optional<std::string> RosTypeStore::find_file(const std::string& package, const std::string& kind,
                                                   const std::string& type) const {
  for (const auto& dir : share_dirs_) {
    std::string path = dir + "/" + package + "/" + kind + "/" + type + "." + kind;
    if (is_regular_file(path)) return path;
  }
  return std::nullopt;
}

const RosMessage& RosTypeStore::message(std::string_view full_name) {
  std::string package, kind, type;
  split_ros_type_name(full_name, package, kind, type);
  if (kind == "srv") throw Error("'" + std::string(full_name) + "' is a service, not a message");
  const std::string key = package + "/msg/" + type;
  if (auto it = messages_.find(key); it != messages_.end()) return *it->second;
  const auto path = find_file(package, "msg", type);
  if (!path) {
    std::string dirs;
    for (const auto& d : share_dirs_) dirs += "\n  " + d;
    throw Error("unknown ROS message type '" + key + "': no " + package + "/msg/" + type +
                ".msg in these share directories:" + (dirs.empty() ? "\n  (none)" : dirs));
  }
  auto parsed = std::make_unique<RosMessage>(parse_msg(package, type, read_text_file(*path)));
  return *messages_.emplace(key, std::move(parsed)).first->second;
}

bool RosTypeStore::has_message(std::string_view full_name) {
  try {
    message(full_name);
    return true;
  } catch (const Error&) {
    return false;
  }
}

const RosService& RosTypeStore::service(std::string_view full_name) {
  std::string package, kind, type;
  split_ros_type_name(full_name, package, kind, type);
  if (kind == "msg") throw Error("'" + std::string(full_name) + "' is a message, not a service");
  const std::string key = package + "/srv/" + type;
  if (auto it = services_.find(key); it != services_.end()) return *it->second;
  const auto path = find_file(package, "srv", type);
  if (!path) throw Error("unknown ROS service type '" + key + "'");
  auto parsed = std::make_unique<RosService>(parse_srv(package, type, read_text_file(*path)));
  return *services_.emplace(key, std::move(parsed)).first->second;
}

std::vector<std::string> RosTypeStore::package_types(std::string_view package, std::string_view kind) {
  std::vector<std::string> names;
  for (const auto& dir : share_dirs_) {
    const std::string path = dir + "/" + std::string(package) + "/" + std::string(kind);
    DIR* d = ::opendir(path.c_str());
    if (!d) continue;
    while (const dirent* entry = ::readdir(d)) {
      const std::string file = entry->d_name;
      const std::string suffix = "." + std::string(kind);
      if (file.size() > suffix.size() && file.compare(file.size() - suffix.size(), suffix.size(), suffix) == 0)
        names.push_back(std::string(package) + "/" + std::string(kind) + "/" +
                        file.substr(0, file.size() - suffix.size()));
    }
    ::closedir(d);
    if (!names.empty()) break;  // first share dir that has the package wins
  }
  std::sort(names.begin(), names.end());
  return names;
}

void RosTypeStore::add(RosMessage message) {
  const std::string key = message.full_name();
  messages_[key] = std::make_unique<RosMessage>(std::move(message));
}

}  // namespace msg_mapping
