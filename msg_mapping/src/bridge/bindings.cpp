// msg_mapping._native.bridge: ln_ros2_bridge's compiled data path for Python.
//
// The Python side passes what it owns as addresses: rclpy's rcl entities
// (`publisher.handle.pointer`, `node.handle.pointer`), a message class's
// `_TYPE_SUPPORT` capsule, ln_core's `client.handle`. It must keep those
// objects alive, and close a path before any of them is destroyed.
#include <nanobind/nanobind.h>
#include <nanobind/stl/string.h>
#include <nanobind/stl/vector.h>

#include <cstdint>

#include "bridge/topic_paths.hpp"

namespace nb = nanobind;
using namespace nb::literals;

namespace msg_mapping::bridge {
namespace {

TopicCodec topic_codec(nb::handle codec) {
  if (nb::isinstance<Codec>(codec)) return TopicCodec(nb::cast<const Codec&>(codec));
  if (nb::isinstance<RuleCodec>(codec)) return TopicCodec(nb::cast<const RuleCodec&>(codec));
  throw nb::type_error("codec must be a msg_mapping Codec or RuleCodec");
}

nb::dict report_dict(const PathReport& r) {
  nb::dict d;
  d["received"] = r.received;
  d["forwarded"] = r.forwarded;
  d["errors"] = r.errors;
  d["lost"] = r.lost;
  d["ignored"] = r.ignored;
  d["held"] = r.held;
  d["new_errors"] = r.error_count_in_text;
  d["error_text"] = r.errors_text;
  d["nodeless"] = r.nodeless;
  d["failed"] = r.failed;
  d["failure"] = r.failure;
  return d;
}

template <class T>
T* address(std::uintptr_t value, const char* what) {
  if (!value) throw nb::value_error((std::string(what) + " is NULL").c_str());
  return reinterpret_cast<T*>(value);
}

}  // namespace

void bind_bridge(nb::module_& parent) {
  nb::module_ m = parent.def_submodule("bridge", "ln_ros2_bridge's per-message data path (LN <-> codec <-> rcl)");

  nb::class_<LnClient>(m, "LnClient", "an LN client handle of the libln this process loaded")
      .def(
          "__init__",
          [](LnClient* self, const std::string& module, std::uintptr_t handle) {
            new (self) LnClient(LnApi::of_module(module), address<void>(handle, "LN client handle"));
          },
          "module"_a, "handle"_a,
          "a client owned elsewhere (ln_core's client.handle); module: the file of the LN package's native module")
      .def(
          "__init__",
          [](LnClient* self, const std::string& module, const std::string& name, const std::string& manager) {
            const LnApi& api = LnApi::of_module(module);
            nb::gil_scoped_release release;
            new (self) LnClient(api, name, manager);
          },
          "module"_a, "name"_a, "manager"_a, "connects a client of its own (LN 2.9, whose Python API hides its handle)")
      .def_prop_ro("name", &LnClient::name)
      .def_prop_ro("library", [](const LnClient& c) { return c.api().path; })
      .def("close", &LnClient::close, nb::call_guard<nb::gil_scoped_release>());

  nb::class_<LnToRosPath>(m, "LnToRosPath", "LN subscription -> codec -> rcl publisher, in a thread of its own")
      .def(
          "__init__",
          [](LnToRosPath* self, LnClient& client, const std::string& topic, const std::string& md_name, double rate,
             unsigned int buffers, bool reliable, nb::handle codec, std::uintptr_t publisher) {
            const TopicCodec converter = topic_codec(codec);
            auto* rcl_publisher = address<rcl_publisher_t>(publisher, "rcl publisher");
            nb::gil_scoped_release release;
            new (self)
                LnToRosPath(client, topic, md_name, LnPortOptions{rate, buffers, reliable}, converter, rcl_publisher);
          },
          "client"_a, "topic"_a, "md_name"_a, "rate"_a, "buffers"_a, "reliable"_a, "codec"_a, "publisher"_a,
          nb::keep_alive<1, 2>(), nb::keep_alive<1, 8>())
      .def("close", &LnToRosPath::close, nb::call_guard<nb::gil_scoped_release>())
      .def("report", [](LnToRosPath& p) { return report_dict(p.report()); });

  nb::class_<RosToLnPath>(m, "RosToLnPath",
                          "rcl subscription -> loop prevention -> codec -> LN, in a thread of its own")
      .def(
          "__init__",
          [](RosToLnPath* self, LnClient& client, const std::string& topic, const std::string& md_name,
             unsigned int buffers, nb::handle codec, std::uintptr_t node, nb::handle type_support,
             const std::string& ros_topic, const std::string& reliability, const std::string& durability,
             const std::string& history, std::size_t depth, std::vector<std::string> bridge_names) {
            const TopicCodec converter = topic_codec(codec);
            auto* rcl_node = address<rcl_node_t>(node, "rcl node");
            void* support = PyCapsule_GetPointer(type_support.ptr(), nullptr);
            if (!support) throw nb::python_error();
            const RosQos qos{reliability, durability, history, depth};
            nb::gil_scoped_release release;
            new (self) RosToLnPath(client, topic, md_name, buffers, converter, rcl_node,
                                   static_cast<const rosidl_message_type_support_t*>(support), ros_topic, qos,
                                   std::move(bridge_names));
          },
          "client"_a, "topic"_a, "md_name"_a, "buffers"_a, "codec"_a, "node"_a, "type_support"_a, "ros_topic"_a,
          "reliability"_a, "durability"_a, "history"_a, "depth"_a, "bridge_names"_a, nb::keep_alive<1, 2>(),
          nb::keep_alive<1, 6>())
      .def_prop_ro("ros_topic", &RosToLnPath::ros_topic)
      .def("close", &RosToLnPath::close, nb::call_guard<nb::gil_scoped_release>())
      .def("report", [](RosToLnPath& p) { return report_dict(p.report()); });
}

}  // namespace msg_mapping::bridge
