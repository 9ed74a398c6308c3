// The files of ln_logger_manager_save, read back independently: raw and
// pcap parsed byte by byte here, MATLAB files with libmatio's reader.
#include "manager/log_files.hpp"

#include <gtest/gtest.h>

#ifdef LN_WITH_MATIO
#include <matio.h>
#endif

#include <signal.h>
#include <sys/stat.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>

#include "manager/mcap_converter.hpp"
#include "manager/request_error.hpp"
#include "manager/test_support.hpp"

namespace ln::manager {
namespace {

using testing::TempDir;

std::string file_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

template <typename T>
T read_at(const std::string& bytes, std::size_t& at) {
  T value;
  std::memcpy(&value, bytes.data() + at, sizeof value);
  at += sizeof value;
  return value;
}

std::string text_at(const std::string& bytes, std::size_t& at) {
  const auto size = read_at<std::uint32_t>(bytes, at);
  std::string text = bytes.substr(at, size);
  at += size;
  return text;
}

class LogFilesTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir.write("t/pt", "double x\nuint8_t flag\n");
    dir.write("t/sample", "define pt_t as \"t/pt\"\nuint32_t counter\npt_t p[2]\nint16_t v[3]\nuint64_t big\n");
    dir.write("t/small", "float f\n");
    library = std::make_unique<md::Library>(md::SearchPath::exactly({dir.path()}));
  }

  /// A topic of `md_name` with `count` samples: packet_counter i + 1, src_ts
  /// `first_ts + i * step`, packet bytes from fill(i, packet).
  SavedTopic topic(const std::string& name, const std::string& md_name, std::uint32_t count, double first_ts,
                   double step, const std::function<void(std::uint32_t, unsigned char*)>& fill, bool only_ts = false) {
    const md::Definition& definition = library->load(md_name);
    SavedTopic saved;
    saved.name = name;
    saved.md_name = md_name;
    saved.md_text = md::python_dict_text(definition);
    saved.md_hash = definition.hash;
    saved.publisher = "pub_" + name;
    saved.message_size = static_cast<std::uint32_t>(md::packet_size(definition));
    saved.only_ts = only_ts;
    saved.columns = flatten_columns(definition);
    auto log = SampleLog::create(std::max<std::uint32_t>(count, 1), 20 + (only_ts ? 0 : saved.message_size));
    std::vector<unsigned char> packet(saved.message_size);
    for (std::uint32_t i = 0; i < count; ++i) {
      std::fill(packet.begin(), packet.end(), 0);
      fill(i, packet.data());
      log->append({first_ts + i * step + 0.001, first_ts + i * step, i + 1}, packet.data(), packet.size());
    }
    saved.samples = log;
    return saved;
  }

  static void fill_sample(std::uint32_t i, unsigned char* packet) {
    // t/sample: counter @0, p[0].x @4, p[0].flag @12, p[1].x @13, p[1].flag @21, v[3] @22, big @28
    const std::uint32_t counter = 100 + i;
    const double x0 = i * 1.5, x1 = -static_cast<double>(i);
    const std::int16_t v[3] = {static_cast<std::int16_t>(i), static_cast<std::int16_t>(-1), 7};
    const std::uint64_t big = (std::uint64_t{1} << 40) + i;
    std::memcpy(packet, &counter, 4);
    std::memcpy(packet + 4, &x0, 8);
    packet[12] = static_cast<unsigned char>(i);
    std::memcpy(packet + 13, &x1, 8);
    packet[21] = 1;
    std::memcpy(packet + 22, v, 6);
    std::memcpy(packet + 28, &big, 8);
  }

  static void fill_small(std::uint32_t i, unsigned char* packet) {
    const float f = 0.5f * static_cast<float>(i);
    std::memcpy(packet, &f, 4);
  }

  TempDir dir;
  std::unique_ptr<md::Library> library;
};

TEST_F(LogFilesTest, ColumnsAreNamedAsLnNamesThem) {
  std::vector<std::string> names;
  std::vector<std::uint32_t> offsets;
  for (const Column& column : flatten_columns(library->load("t/sample"))) {
    names.push_back(column.name + (column.count > 1 ? "*" + std::to_string(column.count) : ""));
    offsets.push_back(column.offset);
  }
  EXPECT_EQ(names, (std::vector<std::string>{"counter", "p[0]_x", "p[0]_flag", "p[1]_x", "p[1]_flag", "v*3", "big"}));
  EXPECT_EQ(offsets, (std::vector<std::uint32_t>{0, 4, 12, 13, 21, 22, 28}));
}

TEST_F(LogFilesTest, FormatsAreChosenByNameAndUnknownOnesListTheKnown) {
  EXPECT_EQ(choose_format("auto", "/x/y.pcap"), "pcap");
  EXPECT_EQ(choose_format("auto", "y.RAW"), "raw");
  EXPECT_EQ(choose_format("auto", "a.b/y.mat"), "mat");
  EXPECT_EQ(choose_format("auto", "y.matlab"), "mat");
  EXPECT_EQ(choose_format("matlab", "y"), "mat");
  EXPECT_EQ(choose_format("matlab4", "y"), "mat4");
  EXPECT_EQ(choose_format("mat4", "y.mat"), "mat4");
  auto refusal = [](const std::string& format, const std::string& filename) {
    try {
      choose_format(format, filename);
    } catch (const RequestError& error) {
      EXPECT_EQ(error.code(), LNE_REQUEST_FAILED);
      return std::string(error.what());
    }
    return std::string("(accepted)");
  };
  EXPECT_NE(refusal("pickle", "y.pickle").find("cannot write Python pickles"), std::string::npos);
  EXPECT_NE(refusal("auto", "y.pickle").find("Python pickle"), std::string::npos);
  EXPECT_NE(refusal("auto", "a.mat/y").find("cannot tell the format"), std::string::npos);
  const std::string unknown = refusal("hdf5", "y.h5");
  EXPECT_NE(unknown.find("unknown format 'hdf5'"), std::string::npos) << unknown;
  EXPECT_NE(unknown.find("raw, pcap, mat, mat4"), std::string::npos) << unknown;
}

TEST_F(LogFilesTest, RawHoldsTheSamplesOfOneTopic) {
  const SavedTopic saved = topic("a.sample", "t/sample", 3, 100.0, 0.01, fill_sample);
  const std::string path = dir.path() + "/one.raw";
  save_log_file(path, "raw", {saved});
  const std::string bytes = file_bytes(path);
  ASSERT_EQ(bytes.size(), 3u * (20 + 36));
  std::string expected(bytes.size(), '\0');
  saved.samples->copy_out(0, expected.data(), expected.size());
  EXPECT_EQ(bytes, expected);

  const std::string two = dir.path() + "/two.raw";
  try {
    save_log_file(two, "raw", {saved, saved});
    FAIL() << "raw wrote two topics";
  } catch (const RequestError& error) {
    EXPECT_NE(std::string(error.what()).find("exactly one topic"), std::string::npos);
  }
  EXPECT_FALSE(dir.exists("two.raw"));
  EXPECT_FALSE(dir.exists("two.raw.ln-tmp-" + std::to_string(::getpid())));
}

TEST_F(LogFilesTest, PcapIsLnsRecorderFormatMergedBySourceTime) {
  // b's packets fall between a's; c never got a publisher.
  const SavedTopic a = topic("a.sample", "t/sample", 3, 100.0, 0.02, fill_sample);
  const SavedTopic b = topic("b.small", "t/small", 2, 100.005, 0.02, fill_small);
  SavedTopic c;
  c.name = "c.none";
  const std::string path = dir.path() + "/log.pcap";
  save_log_file(path, "pcap", {a, b, c});
  const std::string bytes = file_bytes(path);
  std::size_t at = 0;
  EXPECT_EQ(read_at<std::uint32_t>(bytes, at), 0xa1b2c3d4u);
  EXPECT_EQ(read_at<std::uint16_t>(bytes, at), 2);
  EXPECT_EQ(read_at<std::uint16_t>(bytes, at), 4);
  EXPECT_EQ(read_at<std::uint32_t>(bytes, at), 0u);
  EXPECT_EQ(read_at<std::uint32_t>(bytes, at), 0u);
  EXPECT_EQ(read_at<std::uint32_t>(bytes, at), 0xffffffffu);
  EXPECT_EQ(read_at<std::uint32_t>(bytes, at), 147u);
  struct Frame {
    double ts;
    std::uint32_t type;
    std::string data;
  };
  std::vector<Frame> frames;
  while (at < bytes.size()) {
    const auto sec = read_at<std::uint32_t>(bytes, at);
    const auto nsec = read_at<std::uint32_t>(bytes, at);
    const auto length = read_at<std::uint32_t>(bytes, at);
    EXPECT_EQ(read_at<std::uint32_t>(bytes, at), length);
    const auto type = read_at<std::uint32_t>(bytes, at);
    ASSERT_LE(at + length - 4, bytes.size());
    frames.push_back({sec + nsec * 1e-9, type, bytes.substr(at, length - 4)});
    at += length - 4;
  }
  ASSERT_EQ(frames.size(), 1u + 2 + 5);
  EXPECT_EQ(frames[0].type, 0u);  // file version 2
  std::size_t p = 0;
  EXPECT_EQ(read_at<std::uint32_t>(frames[0].data, p), 0xffff0002u);
  EXPECT_NEAR(frames[0].ts, 100.0, 1e-6);
  // One frame per topic with data: id, message size, name, md name, md, publisher, hash.
  for (std::uint32_t id = 0; id < 2; ++id) {
    const SavedTopic& saved = id == 0 ? a : b;
    const Frame& frame = frames[1 + id];
    EXPECT_EQ(frame.type, 1u);
    p = 0;
    EXPECT_EQ(read_at<std::uint32_t>(frame.data, p), id);
    EXPECT_EQ(read_at<std::uint32_t>(frame.data, p), saved.message_size);
    EXPECT_EQ(text_at(frame.data, p), saved.name);
    EXPECT_EQ(text_at(frame.data, p), saved.md_name);
    EXPECT_EQ(text_at(frame.data, p), saved.md_text);
    EXPECT_EQ(text_at(frame.data, p), saved.publisher);
    EXPECT_EQ(text_at(frame.data, p), saved.md_hash);
    EXPECT_EQ(p, frame.data.size());
    EXPECT_NEAR(frame.ts, saved.samples->header(0).src_ts, 1e-6);
  }
  // Packets: topic id, the packet, the publisher's timestamp; in time order.
  const std::vector<std::pair<std::uint32_t, std::uint32_t>> order = {{0, 0}, {1, 0}, {0, 1}, {1, 1}, {0, 2}};
  double previous = 0;
  for (std::size_t k = 0; k < order.size(); ++k) {
    const Frame& frame = frames[3 + k];
    const auto [id, index] = order[k];
    const SavedTopic& saved = id == 0 ? a : b;
    EXPECT_EQ(frame.type, 2u);
    ASSERT_EQ(frame.data.size(), 4 + saved.message_size + 8);
    p = 0;
    EXPECT_EQ(read_at<std::uint32_t>(frame.data, p), id);
    std::string packet(saved.message_size, '\0');
    saved.samples->copy_out(index * saved.samples->sample_size() + 20, packet.data(), packet.size());
    EXPECT_EQ(frame.data.substr(4, saved.message_size), packet);
    p = 4 + saved.message_size;
    const double src_ts = read_at<double>(frame.data, p);
    EXPECT_EQ(src_ts, saved.samples->header(index).src_ts);
    EXPECT_NEAR(frame.ts, src_ts, 1e-6);
    EXPECT_GE(src_ts, previous);
    previous = src_ts;
  }
}

TEST_F(LogFilesTest, PcapRefusesTimestampOnlyLogs) {
  const SavedTopic saved = topic("a.sample", "t/sample", 2, 100.0, 0.01, fill_sample, true);
  EXPECT_THROW(save_log_file(dir.path() + "/ts.pcap", "pcap", {saved}), RequestError);
  EXPECT_FALSE(dir.exists("ts.pcap"));
}

#ifdef LN_WITH_MATIO
struct MatVar {
  matio_classes klass;
  matio_types type;  // MATLAB 4 files have only the double class; their storage type differs
  std::vector<std::size_t> dims;
  std::vector<double> values;  // column-major, converted
};

std::map<std::string, MatVar> read_mat(const std::string& path) {
  std::map<std::string, MatVar> out;
  mat_t* mat = Mat_Open(path.c_str(), MAT_ACC_RDONLY);
  if (mat == nullptr) return out;
  while (matvar_t* var = Mat_VarReadNext(mat)) {
    MatVar read{var->class_type, var->data_type, std::vector<std::size_t>(var->dims, var->dims + var->rank), {}};
    const std::size_t n = var->nbytes / var->data_size;
    for (std::size_t i = 0; i < n; ++i) {
      const auto* at = static_cast<const unsigned char*>(var->data) + i * var->data_size;
      double value = 0;
      switch (var->data_type) {
        case MAT_T_DOUBLE:
          std::memcpy(&value, at, 8);
          break;
        case MAT_T_SINGLE: {
          float f;
          std::memcpy(&f, at, 4);
          value = f;
          break;
        }
        case MAT_T_INT8:
          value = static_cast<std::int8_t>(*at);
          break;
        case MAT_T_UINT8:
          value = *at;
          break;
        case MAT_T_INT16: {
          std::int16_t v;
          std::memcpy(&v, at, 2);
          value = v;
          break;
        }
        case MAT_T_UINT16: {
          std::uint16_t v;
          std::memcpy(&v, at, 2);
          value = v;
          break;
        }
        case MAT_T_INT32: {
          std::int32_t v;
          std::memcpy(&v, at, 4);
          value = v;
          break;
        }
        case MAT_T_UINT32: {
          std::uint32_t v;
          std::memcpy(&v, at, 4);
          value = v;
          break;
        }
        case MAT_T_INT64: {
          std::int64_t v;
          std::memcpy(&v, at, 8);
          value = static_cast<double>(v);
          break;
        }
        case MAT_T_UINT64: {
          std::uint64_t v;
          std::memcpy(&v, at, 8);
          value = static_cast<double>(v);
          break;
        }
        default:
          ADD_FAILURE() << var->name << ": unexpected storage type " << var->data_type;
          break;
      }
      read.values.push_back(value);
    }
    out[var->name] = read;
    Mat_VarFree(var);
  }
  Mat_Close(mat);
  return out;
}

// MATLAB 4 storage types as the file says (libmatio reads them all as
// double): variable name -> P digit of the type field (0 double, 1 single,
// 2 int32, 3 int16, 4 uint16, 5 uint8).
std::map<std::string, int> mat4_storage(const std::string& path) {
  const std::string bytes = file_bytes(path);
  std::map<std::string, int> out;
  std::size_t at = 0;
  while (at + 20 <= bytes.size()) {
    const auto type = read_at<std::int32_t>(bytes, at);
    const auto rows = read_at<std::int32_t>(bytes, at);
    const auto columns = read_at<std::int32_t>(bytes, at);
    read_at<std::int32_t>(bytes, at);  // imaginary
    const auto name_length = read_at<std::int32_t>(bytes, at);
    const std::string name = bytes.substr(at, static_cast<std::size_t>(name_length) - 1);
    at += static_cast<std::size_t>(name_length);
    const int precision = (type / 10) % 10;
    static const std::size_t sizes[] = {8, 4, 4, 2, 2, 1};
    out[name] = precision;
    at += static_cast<std::size_t>(rows) * static_cast<std::size_t>(columns) * sizes[precision];
  }
  return out;
}

TEST_F(LogFilesTest, MatlabFilesHoldOneVariablePerFieldAsLnNamesThem) {
  const SavedTopic a = topic("a.sample", "t/sample", 3, 100.0, 0.01, fill_sample);
  const std::string single = dir.path() + "/one.mat";
  save_log_file(single, "mat", {a});
  auto vars = read_mat(single);
  std::vector<std::string> names;
  for (const auto& entry : vars) names.push_back(entry.first);
  EXPECT_EQ(names, (std::vector<std::string>{"big", "counter", "p_0_flag", "p_0_x", "p_1_flag", "p_1_x",
                                             "packet_counter_", "packet_log_ts_", "packet_source_ts_", "v"}));
  EXPECT_EQ(vars["counter"].klass, MAT_C_UINT32);
  EXPECT_EQ(vars["counter"].dims, (std::vector<std::size_t>{1, 3}));  // a row, like scipy's savemat
  EXPECT_EQ(vars["counter"].values, (std::vector<double>{100, 101, 102}));
  EXPECT_EQ(vars["p_0_x"].values, (std::vector<double>{0, 1.5, 3}));
  EXPECT_EQ(vars["p_1_x"].values, (std::vector<double>{0, -1, -2}));
  EXPECT_EQ(vars["p_0_flag"].klass, MAT_C_UINT8);
  EXPECT_EQ(vars["v"].klass, MAT_C_INT16);
  EXPECT_EQ(vars["v"].dims, (std::vector<std::size_t>{3, 3}));  // samples x elements
  EXPECT_EQ(vars["v"].values, (std::vector<double>{0, 1, 2, -1, -1, -1, 7, 7, 7}));
  EXPECT_EQ(vars["big"].klass, MAT_C_UINT64);
  EXPECT_EQ(vars["packet_counter_"].values, (std::vector<double>{1, 2, 3}));
  EXPECT_EQ(vars["packet_source_ts_"].values, (std::vector<double>{100.0, 100.01, 100.02}));

  // Two topics: each column prefixed by its topic name; MATLAB 4 stores
  // what it lacks (uint32, uint64) as double.
  const SavedTopic b = topic("b.small", "t/small", 2, 200.0, 0.01, fill_small);
  const std::string both = dir.path() + "/both.mat";
  save_log_file(both, "mat4", {a, b});
  vars = read_mat(both);
  EXPECT_EQ(vars.count("a_sample_counter"), 1u);
  EXPECT_EQ(vars.count("a_sample_packet_log_ts"), 1u);
  EXPECT_EQ(vars["a_sample_counter"].values, (std::vector<double>{100, 101, 102}));
  EXPECT_EQ(vars["a_sample_big"].values[2], static_cast<double>((std::uint64_t{1} << 40) + 2));
  EXPECT_EQ(vars["a_sample_v"].values, (std::vector<double>{0, 1, 2, -1, -1, -1, 7, 7, 7}));
  const auto storage = mat4_storage(both);
  EXPECT_EQ(storage.size(), vars.size());
  EXPECT_EQ(storage.at("a_sample_counter"), 0);   // uint32 -> double
  EXPECT_EQ(storage.at("a_sample_big"), 0);       // uint64 -> double
  EXPECT_EQ(storage.at("a_sample_v"), 3);         // int16 kept
  EXPECT_EQ(storage.at("a_sample_p_0_flag"), 5);  // uint8 kept
  EXPECT_EQ(storage.at("b_small_f"), 1);          // single kept
  EXPECT_EQ(vars["b_small_f"].values, (std::vector<double>{0, 0.5}));
  EXPECT_EQ(vars["b_small_packet_counter"].values, (std::vector<double>{1, 2}));
}

TEST_F(LogFilesTest, TimestampOnlyLogsGiveTheHeaderColumns) {
  const SavedTopic a = topic("a.sample", "t/sample", 2, 100.0, 0.01, fill_sample, true);
  const std::string path = dir.path() + "/ts.mat";
  save_log_file(path, "mat", {a});
  const auto vars = read_mat(path);
  EXPECT_EQ(vars.size(), 3u);
  EXPECT_EQ(vars.at("packet_counter_").values, (std::vector<double>{1, 2}));
}

#endif  // LN_WITH_MATIO

TEST_F(LogFilesTest, UnwritablePlacesAreRefusedWithTheReason) {
  const SavedTopic a = topic("a.sample", "t/sample", 1, 100.0, 0.01, fill_sample);
#ifdef LN_WITH_MATIO
  const std::vector<const char*> formats = {"raw", "pcap", "mat", "mat4", "mcap"};
#else
  const std::vector<const char*> formats = {"raw", "pcap", "mcap"};
#endif
  for (const char* format : formats) {
    try {
      save_log_file(dir.path() + "/missing/dir/x", format, {a});
      ADD_FAILURE() << format << ": wrote into a missing directory";
    } catch (const RequestError& error) {
      EXPECT_NE(std::string(error.what()).find("No such file or directory"), std::string::npos) << error.what();
    }
  }
}

// ------------------------------------------------------------------ mcap
// The converter itself (ln_bag's `ln bag convert`) is tested with ln_bag
// (ln_bag/test/test_manager_save.py); here stand-in `ln` scripts check how
// the manager runs it.

/// The names in `path` (a directory).
std::vector<std::string> names_in(const std::string& path) {
  std::vector<std::string> names;
  for (const auto& entry : std::filesystem::directory_iterator(path)) names.push_back(entry.path().filename());
  std::sort(names.begin(), names.end());
  return names;
}

/// An executable `ln` script with `body` in bin/ of `dir`; the environment
/// that finds it first.
std::vector<std::string> fake_ln(const TempDir& dir, const std::string& body) {
  const std::string script = dir.write("bin/ln", "#!/bin/sh\n" + body);
  ::chmod(script.c_str(), 0755);
  return {"PATH=" + dir.path() + "/bin:/usr/bin:/bin", "OUT=" + dir.path()};
}

TEST_F(LogFilesTest, McapIsTheConvertersOutputOfThePcapRenamedIntoPlace) {
  const SavedTopic a = topic("a.sample", "t/sample", 3, 100.0, 0.02, fill_sample);
  TempDir tools, target;
  SaveOptions options;
  options.md_dirs = {dir.path(), "/second dir"};
  // The stand-in copies its input to the output and keeps its arguments.
  options.environment = fake_ln(tools, "printf '%s\\n' \"$@\" > \"$OUT/args\"; cp \"$3\" \"$4\"\n");
  EXPECT_EQ(choose_format("auto", "/x/run.MCAP"), "mcap");
  save_log_file(target.path() + "/run.mcap", "mcap", {a}, options);
  save_log_file(tools.path() + "/reference.pcap", "pcap", {a});
  EXPECT_EQ(file_bytes(target.path() + "/run.mcap"), file_bytes(tools.path() + "/reference.pcap"));
  EXPECT_EQ(names_in(target.path()), std::vector<std::string>{"run.mcap"});  // the pcap is gone
  const std::string pcap = target.path() + "/run.mcap.pcap.ln-tmp-" + std::to_string(::getpid());
  const std::string temp = target.path() + "/run.mcap.ln-tmp-" + std::to_string(::getpid());
  EXPECT_EQ(file_bytes(tools.path() + "/args"), "bag\nconvert\n" + pcap + "\n" + temp + "\n--overwrite\n--md-dir\n" +
                                                    dir.path() + "\n--md-dir\n/second dir\n");
}

TEST_F(LogFilesTest, McapFailuresSayWhyAndLeaveNoFile) {
  const SavedTopic a = topic("a.sample", "t/sample", 2, 100.0, 0.02, fill_sample);
  TempDir target;
  const std::string path = target.path() + "/run.mcap";
  const auto message = [&](const std::vector<std::string>& environment) {
    SaveOptions options;
    options.environment = environment;
    try {
      save_log_file(path, "mcap", {a}, options);
    } catch (const RequestError& error) {
      return std::string(error.what());
    }
    return std::string("(saved)");
  };
  // Coreutils' ln on PATH is not LN's.
  std::string text = message({"PATH=/usr/bin:/bin"});
  EXPECT_NE(text.find("cannot write '" + path + "' as MCAP"), std::string::npos) << text;
  EXPECT_NE(text.find("has no LN `ln` command"), std::string::npos) << text;
  EXPECT_TRUE(names_in(target.path()).empty());

  TempDir tools;
  text = message(fake_ln(tools,
                         "echo half > \"$4\"; echo 'ln: recordings need the ln_bag package (No module named ln_bag)' "
                         ">&2; exit 1\n"));
  EXPECT_NE(text.find("bag convert failed (exit status 1): ln: recordings need the ln_bag package (No module "
                      "named ln_bag)"),
            std::string::npos)
      << text;
  EXPECT_TRUE(names_in(target.path()).empty());

  text = message(fake_ln(tools, "kill -9 $$\n"));
  EXPECT_NE(text.find("failed (killed by SIGKILL): (it printed nothing)"), std::string::npos) << text;

  SavedTopic only_ts = a;
  only_ts.only_ts = true;
  EXPECT_THROW(save_log_file(path, "mcap", {only_ts}), RequestError);
  EXPECT_TRUE(names_in(target.path()).empty());
}

TEST_F(LogFilesTest, AConverterThatTakesTooLongOrOutlivesTheManagerIsStopped) {
  TempDir tools;
  McapConversion conversion;
  conversion.pcap = tools.path() + "/in.pcap";
  conversion.mcap = tools.path() + "/out.mcap";
  conversion.target = "/data/run.mcap";
  conversion.environment = fake_ln(tools, "echo $$ > \"$OUT/pid\"; exec sleep 60\n");
  const auto stopped = [&](const char* words) {
    const auto start = std::chrono::steady_clock::now();
    try {
      convert_pcap_to_mcap(conversion);
      ADD_FAILURE() << "the conversion succeeded";
    } catch (const RequestError& error) {
      EXPECT_NE(std::string(error.what()).find(words), std::string::npos) << error.what();
    }
    EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(20));
    // It ended and was reaped (no zombie).
    const pid_t pid = std::stoi(file_bytes(tools.path() + "/pid"));
    EXPECT_EQ(::kill(pid, 0), -1);
    EXPECT_EQ(errno, ESRCH);
    std::filesystem::remove(tools.path() + "/pid");
  };
  conversion.timeout = std::chrono::milliseconds(1000);
  stopped("bag convert did not finish within 1 s and was stopped");
  conversion.timeout = std::chrono::seconds(60);
  conversion.cancelled = [&] { return tools.exists("pid"); };
  stopped("the manager stops, so");
}

}  // namespace
}  // namespace ln::manager
