#include "ln_bag/topic_mapping.hpp"

#include <fstream>
#include <functional>
#include <set>
#include <sstream>

#include "ln/md/message_definition.hpp"
#include "ln_bag/mcap_writer.hpp"
#include "msg_mapping/ln_to_ros.hpp"

namespace ln_bag {
namespace md = ln::md;
namespace {

std::string read_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream text;
  text << in.rdbuf();
  if (!in) throw BagError("cannot read message definition file " + path);
  return text.str();
}

const msg_mapping::PairedType& part_of(const msg_mapping::PairedInterface& i, const std::string& part) {
  using msg_mapping::InterfaceKind;
  const char* first = i.kind == InterfaceKind::Message   ? "message"
                      : i.kind == InterfaceKind::Service ? "request"
                                                         : "connect";
  const char* second = i.kind == InterfaceKind::Service ? "response" : "call";
  if (part.empty() ? i.kind == InterfaceKind::Message : part == first) return *i.first;
  if (i.second && part == second) return *i.second;
  throw BagError("LN definition '" + i.ln_name + "' has no part '" + part + "' (it is a " +
                 (i.kind == InterfaceKind::Message   ? "message"
                  : i.kind == InterfaceKind::Service ? "service: 'request' or 'response'"
                                                     : "event: 'connect' or 'call'") +
                 ")");
}

// "pkg/msg/Type" -> "pkg/Type", as rosbag2 names the types it appends to a schema.
std::string short_ros_name(const std::string& full) {
  const auto first = full.find('/');
  const auto last = full.rfind('/');
  return first == last ? full : full.substr(0, first) + full.substr(last);
}

}  // namespace

TopicMapping::TopicMapping(const std::string& name, const std::map<std::string, std::string>& texts,
                           const std::vector<std::string>& md_dirs, const std::string& part) {
  try {
    md::Library library(md::SearchPath::exactly(md_dirs));
    for (const auto& [source_name, text] : texts) library.add_source(source_name, text);
    const md::Definition& definition = library.load(name);
    ln_name_ = definition.name;
    ln_hash_ = definition.hash;
    dynamic_ = definition.is_dynamic();
    packet_size_ = definition.kind == md::Kind::Plain ? md::packet_size(definition) : 0;

    std::function<void(const md::Definition&)> collect = [&](const md::Definition& d) {
      if (texts_.count(d.name)) return;
      const auto given = texts.find(d.name);
      texts_[d.name] = given != texts.end() ? given->second : read_file(d.path);
      for (const md::Define& define : d.defines) collect(*define.definition);
    };
    collect(definition);

    msg_mapping::LnToRos generator;
    const msg_mapping::PairedType& type = part_of(generator.add(definition), part);
    ros_type_ = type.ros_name;
    schema_ = msg_mapping::msg_text(type);
    std::set<const msg_mapping::PairedType*> appended{&type};
    std::function<void(const msg_mapping::PairedType&)> append_used = [&](const msg_mapping::PairedType& t) {
      for (const auto& field : t.fields) {
        const msg_mapping::PairedType* used = field.struct_type;
        if (!used || !appended.insert(used).second) continue;
        schema_ +=
            std::string(80, '=') + "\nMSG: " + short_ros_name(used->ros_name) + "\n" + msg_mapping::msg_text(*used);
        append_used(*used);
      }
    };
    append_used(type);
    codec_ = std::make_unique<msg_mapping::Codec>(type);
  } catch (const BagError&) {
    throw;
  } catch (const std::exception& e) {
    const std::string what = e.what();
    if (what.find("'" + name + "'") != std::string::npos) throw BagError(what);  // it names the definition
    throw BagError("LN definition '" + name + "'" + (part.empty() ? "" : " (" + part + ")") + ": " + what);
  }
}

TopicMapping::~TopicMapping() = default;
TopicMapping::TopicMapping(TopicMapping&&) noexcept = default;
TopicMapping& TopicMapping::operator=(TopicMapping&&) noexcept = default;

}  // namespace ln_bag
