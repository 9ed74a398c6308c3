// ln_bag._native: the MCAP writer, the LN -> ROS topic mapping and the
// recorder for Python (the `ln record/play/bag` commands drive them).
#include <nanobind/nanobind.h>
#include <nanobind/stl/map.h>
#include <nanobind/stl/string.h>
#include <nanobind/stl/vector.h>

#include "ln_bag/mcap_writer.hpp"
#include "ln_bag/recorder.hpp"
#include "ln_bag/topic_mapping.hpp"

namespace nb = nanobind;
using namespace ln_bag;

namespace {

// A Python buffer held for the duration of a call.
class BufferView {
 public:
  explicit BufferView(nb::handle object) {
    if (PyObject_GetBuffer(object.ptr(), &view_, PyBUF_SIMPLE) != 0) throw nb::python_error();
  }
  ~BufferView() { PyBuffer_Release(&view_); }
  BufferView(const BufferView&) = delete;
  BufferView& operator=(const BufferView&) = delete;
  msg_mapping::Bytes bytes() const {
    return {static_cast<const std::uint8_t*>(view_.buf), static_cast<std::size_t>(view_.len)};
  }

 private:
  Py_buffer view_{};
};

nb::bytes to_bytes(const std::vector<std::uint8_t>& data) {
  return nb::bytes(reinterpret_cast<const char*>(data.data()), data.size());
}

// Every failure of this module is a BagError; codec errors say which
// definition they are about (nanobind's exception translators are
// process-wide, so msg_mapping's own types must not escape from here).
template <class F>
auto guarded(const std::string& what, F&& f) {
  try {
    return f();
  } catch (const BagError&) {
    throw;
  } catch (const std::exception& e) {
    throw BagError(what + ": " + e.what());
  }
}

nb::dict stats_dict(const TopicStats& s) {
  nb::dict d;
  d["topic"] = s.topic;
  d["channel_id"] = s.channel_id;
  d["messages"] = s.messages;
  d["bytes"] = s.bytes;
  d["lost"] = s.lost;
  d["buffers"] = s.buffers;
  d["error"] = s.error;
  return d;
}

}  // namespace

NB_MODULE(_native, m) {
  m.doc() = "ln_bag: MCAP recordings of LN topics (C++)";
  nb::exception<BagError>(m, "BagError", PyExc_RuntimeError);

  nb::class_<McapWriter>(m, "McapWriter", "an MCAP file being written (chunked, indexed, ROS 2 profile)")
      .def(
          "__init__",
          [](McapWriter* self, const std::string& path, std::size_t chunk_size, std::size_t queue_bytes) {
            WriterOptions o;
            o.chunk_size = chunk_size;
            o.queue_bytes = queue_bytes;
            new (self) McapWriter(path, o);
          },
          nb::arg("path"), nb::arg("chunk_size") = WriterOptions{}.chunk_size,
          nb::arg("queue_bytes") = WriterOptions{}.queue_bytes)
      .def("add_schema", &McapWriter::add_schema, nb::arg("name"), nb::arg("encoding"), nb::arg("data"))
      .def("add_channel", &McapWriter::add_channel, nb::arg("schema_id"), nb::arg("topic"), nb::arg("message_encoding"),
           nb::arg("metadata"))
      .def(
          "add_message",
          [](McapWriter& w, std::uint16_t channel, std::uint32_t sequence, std::uint64_t log_time,
             std::uint64_t publish_time, nb::handle data) {
            BufferView view(data);
            w.add_message(channel, sequence, log_time, publish_time, view.bytes().data, view.bytes().size);
          },
          nb::arg("channel_id"), nb::arg("sequence"), nb::arg("log_time"), nb::arg("publish_time"), nb::arg("data"))
      .def("flush_chunk", &McapWriter::flush_chunk)
      .def("close", &McapWriter::close, nb::call_guard<nb::gil_scoped_release>())
      .def_prop_ro("committed_messages", &McapWriter::committed_messages)
      .def_prop_ro("committed_bytes", &McapWriter::committed_bytes)
      .def_prop_ro("written",
                   [](const McapWriter& w) {
                     const WrittenStats s = w.written();
                     nb::dict d;
                     d["messages"] = s.messages;
                     d["chunks"] = s.chunks;
                     d["file_bytes"] = s.file_bytes;
                     d["write_seconds"] = s.write_seconds;
                     return d;
                   })
      .def_prop_ro("error", &McapWriter::error)
      .def_prop_ro("path", &McapWriter::path);

  nb::class_<TopicMapping>(m, "TopicMapping",
                           "an LN definition's ROS 2 type, ros2msg schema and codec (LN bytes <-> CDR)")
      .def(nb::init<const std::string&, const std::map<std::string, std::string>&, const std::vector<std::string>&,
                    const std::string&>(),
           nb::arg("name"), nb::arg("texts") = std::map<std::string, std::string>{},
           nb::arg("md_dirs") = std::vector<std::string>{}, nb::arg("part") = "")
      .def_prop_ro("ln_name", &TopicMapping::ln_name)
      .def_prop_ro("ln_hash", &TopicMapping::ln_hash)
      .def_prop_ro("ros_type", &TopicMapping::ros_type)
      .def_prop_ro("schema", &TopicMapping::schema)
      .def_prop_ro("packet_size", &TopicMapping::packet_size)
      .def_prop_ro("dynamic", &TopicMapping::dynamic)
      .def_prop_ro("texts", &TopicMapping::texts)
      .def("ln_to_cdr",
           [](const TopicMapping& t, nb::handle ln) {
             BufferView view(ln);
             return to_bytes(
                 guarded("'" + t.ln_name() + "' LN -> CDR", [&] { return t.codec().ln_to_cdr(view.bytes()); }));
           })
      .def("cdr_to_ln", [](const TopicMapping& t, nb::handle cdr) {
        BufferView view(cdr);
        return to_bytes(guarded("'" + t.ln_name() + "' CDR -> LN", [&] { return t.codec().cdr_to_ln(view.bytes()); }));
      });

  nb::class_<Recorder>(m, "Recorder", "records LN topics into an McapWriter from a thread of its own")
      .def(
          "__init__",
          [](Recorder* self, McapWriter& writer, const std::string& manager, const std::string& client_name,
             std::uint64_t max_messages, double max_seconds, double batch_seconds, double chunk_seconds) {
            RecorderOptions o;
            o.manager = manager;
            o.client_name = client_name;
            o.max_messages = max_messages;
            o.max_seconds = max_seconds;
            o.batch_seconds = batch_seconds;
            o.chunk_seconds = chunk_seconds;
            nb::gil_scoped_release release;
            new (self) Recorder(writer, o);
          },
          nb::arg("writer"), nb::arg("manager"), nb::arg("client_name") = "ln_record", nb::arg("max_messages") = 0,
          nb::arg("max_seconds") = 0.0, nb::arg("batch_seconds") = RecorderOptions{}.batch_seconds,
          nb::arg("chunk_seconds") = RecorderOptions{}.chunk_seconds, nb::keep_alive<1, 2>())
      .def("add_topic", &Recorder::add_topic, nb::arg("topic"), nb::arg("ros_topic"), nb::arg("mapping"),
           nb::arg("metadata"), nb::arg("buffers"), nb::call_guard<nb::gil_scoped_release>())
      .def("add_channel", &Recorder::add_channel, nb::arg("ros_topic"), nb::arg("mapping"), nb::arg("metadata"),
           nb::call_guard<nb::gil_scoped_release>())
      .def(
          "post_message",
          [](Recorder& r, std::uint16_t channel, std::uint32_t sequence, std::uint64_t log_time,
             std::uint64_t publish_time, nb::bytes data) {
            std::string copy(data.c_str(), data.size());
            nb::gil_scoped_release release;
            r.post_message(channel, sequence, log_time, publish_time, std::move(copy));
          },
          nb::arg("channel_id"), nb::arg("sequence"), nb::arg("log_time"), nb::arg("publish_time"), nb::arg("data"))
      .def("start", &Recorder::start)
      .def("wait", &Recorder::wait, nb::arg("timeout"), nb::call_guard<nb::gil_scoped_release>())
      .def("stop", &Recorder::stop, nb::call_guard<nb::gil_scoped_release>())
      .def_prop_ro("error", &Recorder::error)
      .def_prop_ro("messages", &Recorder::messages)
      .def("stats", [](const Recorder& r) {
        nb::list out;
        for (const TopicStats& s : r.stats()) out.append(stats_dict(s));
        return out;
      });
}
