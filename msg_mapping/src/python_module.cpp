// msg_mapping._native: the C++ mapping and codecs for Python.
//
// Conversions take any object with the buffer protocol (bytes, bytearray,
// memoryview, numpy arrays) and return bytes, or write into a writable buffer
// (`*_into`), so no per-field Python work happens anywhere.
#include <nanobind/nanobind.h>
#include <nanobind/stl/map.h>
#include <nanobind/stl/optional.h>
#include <nanobind/stl/pair.h>
#include <nanobind/stl/set.h>
#include <nanobind/stl/string.h>
#include <nanobind/stl/string_view.h>
#include <nanobind/stl/vector.h>

#include <memory>

#include "msg_mapping/codec.hpp"
#include "msg_mapping/ln_to_ros.hpp"
#include "msg_mapping/naming.hpp"
#include "msg_mapping/ros_to_ln.hpp"
#include "msg_mapping/rules.hpp"

namespace nb = nanobind;
namespace md = ln::md;
using namespace msg_mapping;

namespace msg_mapping::bridge {
void bind_bridge(nb::module_& parent);  // bridge/bindings.cpp
}

namespace {

// A Python buffer held for the duration of a call.
class BufferView {
 public:
  BufferView(nb::handle object, bool writable) {
    if (PyObject_GetBuffer(object.ptr(), &view_, writable ? PyBUF_WRITABLE : PyBUF_SIMPLE) != 0)
      throw nb::python_error();
    if (!PyBuffer_IsContiguous(&view_, 'C')) {
      PyBuffer_Release(&view_);
      throw nb::type_error("the buffer must be C-contiguous");
    }
  }
  ~BufferView() { PyBuffer_Release(&view_); }
  BufferView(const BufferView&) = delete;
  BufferView& operator=(const BufferView&) = delete;

  Bytes bytes() const { return {static_cast<const std::uint8_t*>(view_.buf), static_cast<std::size_t>(view_.len)}; }
  MutableBytes mutable_bytes() const {
    return {static_cast<std::uint8_t*>(view_.buf), static_cast<std::size_t>(view_.len)};
  }

 private:
  Py_buffer view_{};
};

// Conversions of large messages let other Python threads run meanwhile.
constexpr std::size_t release_gil_above = 64 * 1024;

template <class F>
auto maybe_without_gil(std::size_t size, F&& f) {
  if (size > release_gil_above) {
    nb::gil_scoped_release release;
    return f();
  }
  return f();
}

nb::bytes new_bytes(std::size_t size, std::uint8_t*& data) {
  PyObject* object = PyBytes_FromStringAndSize(nullptr, static_cast<Py_ssize_t>(size));
  if (!object) throw nb::python_error();
  data = reinterpret_cast<std::uint8_t*>(PyBytes_AS_STRING(object));
  return nb::steal<nb::bytes>(object);
}

nb::bytes ln_to_cdr(const Codec& codec, nb::handle ln) {
  BufferView in(ln, false);
  const std::size_t size = codec.cdr_size(in.bytes());
  std::uint8_t* out = nullptr;
  nb::bytes result = new_bytes(size, out);
  maybe_without_gil(size, [&] { return codec.ln_to_cdr(in.bytes(), {out, size}); });
  return result;
}

nb::bytes cdr_to_ln(const Codec& codec, nb::handle cdr) {
  BufferView in(cdr, false);
  const std::size_t size = codec.fixed_ln_size() ? codec.fixed_ln_size() : codec.ln_size(in.bytes());
  std::uint8_t* out = nullptr;
  nb::bytes result = new_bytes(size, out);
  maybe_without_gil(size, [&] { return codec.cdr_to_ln(in.bytes(), {out, size}); });
  return result;
}

std::size_t ln_to_cdr_into(const Codec& codec, nb::handle ln, nb::handle out) {
  BufferView in(ln, false), target(out, true);
  return maybe_without_gil(in.bytes().size, [&] { return codec.ln_to_cdr(in.bytes(), target.mutable_bytes()); });
}

std::size_t cdr_to_ln_into(const Codec& codec, nb::handle cdr, nb::handle out) {
  BufferView in(cdr, false), target(out, true);
  return maybe_without_gil(in.bytes().size, [&] { return codec.cdr_to_ln(in.bytes(), target.mutable_bytes()); });
}

// md::Library with the search path it was made from.
struct PyLibrary {
  std::unique_ptr<md::Library> library;
  explicit PyLibrary(std::vector<std::string> md_dirs, bool standard)
      : library(std::make_unique<md::Library>(standard ? md::SearchPath::standard(std::move(md_dirs))
                                                       : md::SearchPath::exactly(std::move(md_dirs)))) {}
};

nb::dict interface_dict(const PairedInterface& i) {
  nb::dict d;
  d["ln_name"] = i.ln_name;
  d["ln_hash"] = i.ln_hash;
  d["kind"] = i.kind == InterfaceKind::Message ? "message" : i.kind == InterfaceKind::Service ? "service" : "event";
  d["ros_type"] = i.ros_name;
  d["first"] = i.first->ros_name;
  if (i.second) d["second"] = i.second->ros_name;
  return d;
}

// The part names of an interface kind: message | request, response | connect, call.
constexpr const char* part_names[3][2] = {{"message", ""}, {"request", "response"}, {"connect", "call"}};

const PairedType& part_of(const PairedInterface& i, std::string part) {
  const auto& names = part_names[static_cast<int>(i.kind)];
  if (part.empty() && i.kind == InterfaceKind::Message) part = "message";
  if (part == names[0]) return *i.first;
  if (!part.empty() && part == names[1]) return *i.second;
  const std::string expected =
      i.kind == InterfaceKind::Message ? "'message'" : "'" + std::string(names[0]) + "' or '" + names[1] + "'";
  if (part.empty())
    throw Error("'" + i.ln_name + "' is a " + (i.kind == InterfaceKind::Service ? "service" : "event") +
                ": say which part (" + expected + ")");
  throw Error("'" + i.ln_name + "' has no part '" + part + "' (expected " + expected + ")");
}

nb::list packages_list(const std::vector<GeneratedPackage>& packages) {
  nb::list out;
  for (const auto& p : packages) {
    nb::dict d;
    d["name"] = p.name;
    d["ln_definitions"] = p.ln_definitions;
    d["dependencies"] = p.dependencies;
    nb::dict files;
    for (const auto& f : p.files) files[nb::str(f.path.c_str())] = nb::str(f.content.c_str(), f.content.size());
    d["files"] = files;
    out.append(d);
  }
  return out;
}

}  // namespace

NB_MODULE(_native, m) {
  m.doc() = "msg_mapping: LN <-> ROS 2 interface mapping and LN <-> CDR codecs (C++)";

  nb::exception<CodecError>(m, "CodecError", PyExc_ValueError);
  nb::exception<Error>(m, "MappingError", PyExc_ValueError);
  nb::exception<md::Error>(m, "DefinitionError", PyExc_ValueError);

  // ------------------------------------------------------------- naming
  m.def("camel_to_snake", &camel_to_snake);
  m.def("ros_field_name_for", [](const std::string& name) {
    std::string why;
    std::string out = ros_field_name_for(name, &why);
    return std::make_pair(out, why);
  });
  m.def("ros_type_name_for", [](const std::string& ln_name, const std::string& package_suffix,
                                const std::string& root_package, const std::string& single_package) {
    NamingOptions o{package_suffix, root_package, single_package};
    const RosTypeName n = ros_type_name_for(ln_name, o);
    return std::make_pair(n.package, n.type);
  });
  m.def("is_reserved_identifier", &is_reserved_identifier);
  m.def("definition_names_under", &definition_names_under);

  // ------------------------------------------------------------- LN model
  nb::class_<PyLibrary>(m, "Library", "ln_core's message-definition library (one search path)")
      .def(nb::init<std::vector<std::string>, bool>(), nb::arg("md_dirs") = std::vector<std::string>{},
           nb::arg("standard") = false,
           "standard=True: LN's full search order (built-in dirs, LN_MESSAGE_DEFINITION_DIRS, md.conf) after md_dirs")
      .def("add_source",
           [](PyLibrary& l, const std::string& name, const std::string& text) { l.library->add_source(name, text); })
      .def("load",
           [](PyLibrary& l, const std::string& name) {
             const md::Definition& d = l.library->load(name);
             nb::dict out;
             out["name"] = d.name;
             out["path"] = d.path;
             out["hash"] = d.hash;
             out["kind"] = d.kind == md::Kind::Plain ? "plain" : d.kind == md::Kind::Service ? "service" : "event";
             out["dynamic"] = d.is_dynamic();
             out["packet_size"] = md::packet_size(d);
             return out;
           })
      .def("source_files",
           [](PyLibrary& l, const std::vector<std::string>& names) {
             // The files a set of definitions was read from (for build dependencies).
             std::set<std::string> files;
             std::vector<const md::Definition*> todo;
             for (const auto& n : names) todo.push_back(&l.library->load(n));
             std::set<const md::Definition*> seen;
             while (!todo.empty()) {
               const md::Definition* d = todo.back();
               todo.pop_back();
               if (!seen.insert(d).second) continue;
               if (!d->path.empty() && d->path[0] != '<') files.insert(d->path);
               for (const auto& def : d->defines) todo.push_back(def.definition);
             }
             return std::vector<std::string>(files.begin(), files.end());
           })
      .def_prop_ro("search_dirs", [](PyLibrary& l) { return l.library->search_path().dirs(); });

  // ------------------------------------------------------------- LN -> ROS
  nb::class_<LnToRos>(m, "LnToRos", "maps LN definitions to ROS 2 interface packages")
      .def(
          "__init__",
          [](LnToRos* self, const std::string& package_suffix, const std::string& root_package,
             const std::string& single_package) {
            new (self) LnToRos(NamingOptions{package_suffix, root_package, single_package});
          },
          nb::arg("package_suffix") = "_ln_msgs", nb::arg("root_package") = "ln_msgs", nb::arg("single_package") = "")
      .def("add", [](LnToRos& g, PyLibrary& lib,
                     const std::string& name) { return interface_dict(g.add(lib.library->load(name))); })
      .def("interfaces",
           [](const LnToRos& g) {
             nb::list out;
             for (const auto* i : g.interfaces()) out.append(interface_dict(*i));
             return out;
           })
      .def("packages", [](const LnToRos& g) { return packages_list(g.packages()); })
      .def(
          "codec",
          [](const LnToRos& g, const std::string& ln_name, const std::string& part) {
            const PairedInterface* i = g.find(ln_name);
            if (!i) throw Error("LN definition '" + ln_name + "' has not been added");
            return Codec(part_of(*i, part));
          },
          nb::arg("ln_name"), nb::arg("part") = "");

  // ------------------------------------------------------------- ROS -> LN
  nb::class_<RosToLn>(m, "RosToLn", "maps ROS 2 .msg/.srv types to LN definitions")
      .def(
          "__init__",
          [](RosToLn* self, std::vector<std::string> share_dirs, const std::string& prefix,
             std::uint32_t string_capacity, std::uint32_t sequence_capacity,
             std::map<std::string, std::uint32_t> capacities) {
            RosToLnOptions o;
            o.prefix = prefix;
            o.default_string_capacity = string_capacity;
            o.default_sequence_capacity = sequence_capacity;
            o.capacities = std::move(capacities);
            new (self) RosToLn(std::move(share_dirs), std::move(o));
          },
          nb::arg("share_dirs"), nb::arg("prefix") = "ros2", nb::arg("string_capacity") = 255,
          nb::arg("sequence_capacity") = 64, nb::arg("capacities") = std::map<std::string, std::uint32_t>{})
      .def(
          "add",
          [](RosToLn& g, const std::string& ros_type, bool dynamic) {
            return interface_dict(g.add(ros_type, dynamic));
          },
          nb::arg("ros_type"), nb::arg("dynamic") = false)
      .def("package_types", [](RosToLn& g, const std::string& package,
                               const std::string& kind) { return g.store().package_types(package, kind); })
      .def("definitions",
           [](const RosToLn& g) {
             nb::dict out;
             for (const auto& [name, text] : g.definitions()) out[nb::str(name.c_str())] = text;
             return out;
           })
      .def("mapping_json", &RosToLn::mapping_json)
      .def(
          "codec",
          [](const RosToLn& g, const std::string& ros_type, bool dynamic, const std::string& part) {
            const PairedInterface* i = g.find(ros_type, dynamic);
            if (!i) throw Error("ROS type '" + ros_type + "' has not been added");
            return Codec(part_of(*i, part));
          },
          nb::arg("ros_type"), nb::arg("dynamic") = false, nb::arg("part") = "");

  // ------------------------------------------------------------- rules
  m.def(
      "compile_rule",
      [](PyLibrary& lib, RosToLn& ros, const std::string& ln_name, const std::string& ros_type,
         const std::vector<std::map<std::string, std::string>>& fields) {
        std::vector<FieldRule> rules;
        for (const auto& f : fields) {
          FieldRule r;
          for (const auto& [key, value] : f) {
            if (key == "ros")
              r.ros_path = value;
            else if (key == "from")
              r.ln_path = value;
            else if (key == "value")
              r.constant = value, r.has_constant = true;
            else if (key == "scale")
              r.scale = value;
            else if (key == "offset")
              r.offset = value;
            else if (key == "convert")
              r.convert = value;
            else if (key == "lossy")
              r.lossy = value == "true";
            else
              throw Error("rule for " + ln_name + " -> " + ros_type + ": unknown key '" + key + "'");
          }
          rules.push_back(std::move(r));
        }
        return RuleCodec(lib.library->load(ln_name), ros, ros_type, rules);
      },
      nb::arg("library"), nb::arg("ros"), nb::arg("ln_name"), nb::arg("ros_type"), nb::arg("fields"));

  nb::class_<RuleCodec>(m, "RuleCodec", "an LN definition mapped onto an existing ROS type by rules")
      .def_prop_ro("ln_name", &RuleCodec::ln_name)
      .def_prop_ro("ros_name", &RuleCodec::ros_name)
      .def_prop_ro("ln_size", &RuleCodec::ln_size)
      .def("ln_to_cdr",
           [](const RuleCodec& c, nb::handle ln) {
             BufferView in(ln, false);
             const std::vector<std::uint8_t> out = c.ln_to_cdr(in.bytes());
             return nb::bytes(reinterpret_cast<const char*>(out.data()), out.size());
           })
      .def("cdr_to_ln",
           [](const RuleCodec& c, nb::handle cdr) {
             BufferView in(cdr, false);
             const std::vector<std::uint8_t> out = c.cdr_to_ln(in.bytes());
             return nb::bytes(reinterpret_cast<const char*>(out.data()), out.size());
           })
      .def("describe", &RuleCodec::describe);

  // ------------------------------------------------------------- codecs
  nb::class_<Codec>(m, "Codec", "LN flat bytes <-> CDR for one paired type")
      .def_prop_ro("ros_name", &Codec::ros_name)
      .def_prop_ro("ln_name", &Codec::ln_name)
      .def_prop_ro("fixed_ln_size", &Codec::fixed_ln_size)
      .def_prop_ro("fixed_cdr_size", &Codec::fixed_cdr_size)
      .def("ln_to_cdr", &ln_to_cdr, nb::arg("ln"), "LN flat bytes -> CDR bytes (header included)")
      .def("cdr_to_ln", &cdr_to_ln, nb::arg("cdr"), "CDR bytes -> LN flat bytes")
      .def("ln_to_cdr_into", &ln_to_cdr_into, nb::arg("ln"), nb::arg("out"), "writes CDR into `out`; returns its size")
      .def("cdr_to_ln_into", &cdr_to_ln_into, nb::arg("cdr"), nb::arg("out"), "writes LN into `out`; returns its size")
      .def("cdr_size",
           [](const Codec& c, nb::handle ln) {
             BufferView in(ln, false);
             return c.cdr_size(in.bytes());
           })
      .def("ln_size",
           [](const Codec& c, nb::handle cdr) {
             BufferView in(cdr, false);
             return c.ln_size(in.bytes());
           })
      .def("describe", &Codec::describe);

  bridge::bind_bridge(m);
}
