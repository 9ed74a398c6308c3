// Parameters as an LN 2.9 program uses them (ln/parameters.h,
// ln/parameter_client.h), built unchanged against LN 2.9 and against
// ln_core. Prints what it observes, one line per step, without error texts
// (they differ); test_ln29b_parameters.py compares the transcripts.
//
//   lnbt_parameters provide GROUP   provider "lnbt_param_provider" of block GROUP:
//                                   "ready", "applied limit N" per accepted
//                                   override, and at the end (stdin closed)
//                                   "out ..." with every output
//   lnbt_parameters client GROUP    reads, overrides and resets GROUP's
//                                   parameters, also through the raw services
#include <ln/ln.h>
#include <ln/parameter_client.h>
#include <ln/parameters.h>
#include <poll.h>

#include <array>
#include <cinttypes>
#include <cstdio>
#include <cstring>
#include <functional>
#include <string>
#include <vector>

#include "ln_messages.h"

using ln::parameters::port_description;

namespace {

std::string join(const std::vector<double>& values) {
  std::string out;
  for (double v : values) {
    char text[32];
    std::snprintf(text, sizeof text, "%s%.17g", out.empty() ? "" : ",", v);
    out += text;
  }
  return out;
}

std::string rows(const std::vector<std::vector<double>>& matrix) {
  std::string out;
  for (const auto& row : matrix) out += (out.empty() ? "" : "|") + join(row);
  return out;
}

int provide(const std::string& group) {
  ln::client clnt("lnbt_param_provider");
  double gain = 1.5, gain_o = 0;
  int32_t count = 7, count_o = 0;
  float vec[3] = {1, 2.5f, -3}, vec_o[3] = {};
  double mat[2][3] = {{1, 2, 3}, {4, 5, 6}}, mat_o[2][3] = {};
  bool flag = true, flag_o = false;
  uint8_t u8 = 200, u8_o = 0;
  uint64_t big = UINT64_MAX, big_o = 0;
  int64_t neg = -9000000000LL, neg_o = 0;
  double row[1][3] = {{7, 8, 9}}, row_o[1][3] = {};
  int16_t col[3][1] = {{1}, {2}, {3}}, col_o[3][1] = {};
  int32_t limit = 5, limit_o = 0;
  double deep = 0.25, deep_o = 0;
  ln::parameters::parameter_block block(&clnt, group);
  const bool ok = block.register_parameters(
      port_description<double>("gain", "the gain", &gain, &gain_o),
      port_description<int32_t>("count", "a count", &count, &count_o),
      port_description<float[3]>("vec", "", &vec, &vec_o),
      port_description<double[2][3]>("mat", "a matrix", &mat, &mat_o),
      port_description<bool>("flag", "it's \"quoted\"", &flag, &flag_o),
      port_description<uint8_t>("u8", "", &u8, &u8_o), port_description<uint64_t>("big", "", &big, &big_o),
      port_description<int64_t>("neg", "", &neg, &neg_o), port_description<double[1][3]>("row", "", &row, &row_o),
      port_description<int16_t[3][1]>("col", "", &col, &col_o),
      port_description<int32_t>(
          "limit", "below 10", &limit, &limit_o, [](int32_t& v) { return v < 10; },
          [](int32_t& v) { std::printf("applied limit %d\n", v), std::fflush(stdout); }),
      port_description<double>("sub.deep", "", &deep, &deep_o));
  std::printf("register %d\n", ok);
  ln::parameters::parameter_block duplicate(&clnt, group);
  double other = 0, other_o = 0;
  std::printf("duplicate register %d\n",
              duplicate.register_parameters(port_description<double>("gain", "", &other, &other_o)));
  std::printf("ready\n");
  std::fflush(stdout);
  for (int i = 0; i < 60000; ++i) {
    block.update();
    pollfd in{0, POLLIN, 0};
    if (poll(&in, 1, 1) > 0) break;  // stdin closed: done
  }
  std::printf("out gain=%.17g count=%d vec=%g,%g,%g mat=%g,%g,%g,%g,%g,%g flag=%d u8=%d big=%" PRIu64 " neg=%" PRId64
              " row=%g,%g,%g col=%d,%d,%d limit=%d deep=%g\n",
              gain_o, count_o, vec_o[0], vec_o[1], vec_o[2], mat_o[0][0], mat_o[0][1], mat_o[0][2], mat_o[1][0],
              mat_o[1][1], mat_o[1][2], flag_o, u8_o, big_o, neg_o, row_o[0][0], row_o[0][1], row_o[0][2], col_o[0][0],
              col_o[1][0], col_o[2][0], limit_o, deep_o);
  return 0;
}

void step(const char* what, const std::function<std::string()>& body) {
  try {
    std::printf("%s: %s\n", what, body().c_str());
  } catch (const std::exception&) {
    std::printf("%s: error\n", what);
  }
  std::fflush(stdout);
}

std::string hex(const uint8_t* data, uint32_t len) {
  std::string out;
  for (uint32_t i = 0; i < len; ++i) {
    char byte[3];
    std::snprintf(byte, sizeof byte, "%02x", data[i]);
    out += byte;
  }
  return out;
}

int client(const std::string& group) {
  ln::client clnt("lnbt_param_client");
  // The provider's raw answers: the same text and bytes from both systems.
  ln::service* dict = clnt.get_service("ln.parameters.query_dict.lnbt_param_provider", "ln/parameters/query_dict",
                                       LN_PARAMETERS_QUERY_DICT_SIGNATURE);
  ln_parameters_query_dict_t d{};
  std::string pattern = group + ".*";
  d.req.pattern = &pattern[0];
  d.req.pattern_len = static_cast<uint32_t>(pattern.size());
  dict->call(&d);
  std::printf("query_dict %s", std::string(d.resp.data, d.resp.data_len).c_str());
  ln::service* query =
      clnt.get_service("ln.parameters.query.lnbt_param_provider", "ln/parameters/query", LN_PARAMETERS_QUERY_SIGNATURE);
  ln_parameters_query_t q{};
  q.req.pattern = &pattern[0];
  q.req.pattern_len = static_cast<uint32_t>(pattern.size());
  query->call(&q);
  for (uint32_t i = 0; i < q.resp.values_len; ++i) {
    const ln_parameters_value_t& v = q.resp.values[i];
    std::printf("query %s %s %d %s %s\n", std::string(v.name, v.name_len).c_str(),
                std::string(v.data_type, v.data_type_len).c_str(), v.override_enabled,
                hex(v.input_data, v.input_data_len).c_str(), hex(v.output_data, v.output_data_len).c_str());
  }

  auto p = clnt.get_parameters(group);
  step("gain", [&] { return join({p.get_input<double>("gain"), p.get_output<double>("gain")}); });
  step("gain as int", [&] { return std::to_string(p.get_input<int>("gain")); });
  step("count as double", [&] { return join({p.get_input<double>("count")}); });
  step("count as uint8", [&] { return std::to_string(p.get_input<uint8_t>("count")); });
  step("u8 as int8", [&] { return std::to_string(p.get_input<int8_t>("u8")); });
  step("big", [&] { return std::to_string(p.get_input<uint64_t>("big")); });
  step("big as int64", [&] { return std::to_string(p.get_input<int64_t>("big")); });
  step("neg", [&] { return std::to_string(p.get_input<int64_t>("neg")); });
  step("neg as int32", [&] { return std::to_string(p.get_input<int32_t>("neg")); });
  step("flag", [&] { return std::to_string(p.get_input<bool>("flag")); });
  step("vec", [&] { return join(p.get_input<std::vector<double>>("vec")); });
  step("vec as array3", [&] {
    auto a = p.get_input<std::array<float, 3>>("vec");
    return join({a[0], a[1], a[2]});
  });
  step("vec as array2", [&] { return std::to_string(p.get_input<std::array<float, 2>>("vec")[0]); });
  step("vec as scalar", [&] { return join({p.get_input<double>("vec")}); });
  step("mat", [&] {
    auto m = p.get_input<std::vector<std::vector<double>>>("mat");
    return std::to_string(m.size()) + "x" + std::to_string(m[0].size()) + " " + join(m[1]);
  });
  step("mat as vector", [&] { return join(p.get_input<std::vector<double>>("mat")); });
  step("row", [&] { return join(p.get_input<std::vector<std::vector<double>>>("row")[0]); });
  step("row as vector", [&] { return join(p.get_input<std::vector<double>>("row")); });
  step("col", [&] {
    auto c = p.get_input<std::array<std::array<int, 1>, 3>>("col");
    return std::to_string(c[0][0]) + "," + std::to_string(c[2][0]);
  });
  step("description", [&] { return p.get_description("flag") + "|" + p.get_description("mat"); });
  step("internal", [&] {
    const ln::parameters::parameter_value v = p.get_internal_value("mat");
    return v.full_name + " " + v.data_type + " " + std::to_string(v.element_data_type) + " " +
           std::to_string(v.scalar_size) + " " + std::to_string(v.shape.size()) + " " +
           std::to_string(static_cast<int>(v.scalar_kind)) + " " + join(v.input_float);
  });
  step("internal neg", [&] {
    const ln::parameters::parameter_value v = p.get_internal_value("neg");
    return std::to_string(v.input_integer[0]) + " " + std::to_string(static_cast<int>(v.scalar_kind));
  });
  step("strict gain as int", [&] { return std::to_string(clnt.get_parameters(group, true).get_input<int>("gain")); });
  step("strict count as int64",
       [&] { return std::to_string(clnt.get_parameters(group, true).get_input<int64_t>("count")); });
  step("unknown", [&] { return join({p.get_input<double>("nothere")}); });
  step("unknown group", [&] { return join({clnt.get_parameters("nogroup").get_input<double>("x")}); });

  step("set gain", [&] {
    p.set_override("gain", 2.5);
    return join({p.get_input<double>("gain"), p.get_output<double>("gain")}) + " " +
           std::to_string(p.get_internal_value("gain").override_enabled);
  });
  step("set count from double", [&] {
    p.set_override("count", 3.9);
    return std::to_string(p.get_output<int>("count"));
  });
  step("set u8 too big", [&] {
    p.set_override("u8", 300);
    return std::string("set");
  });
  step("set u8 negative", [&] {
    p.set_override("u8", -1);
    return std::string("set");
  });
  step("set neg", [&] {
    p.set_override("neg", int64_t(-5));
    return std::to_string(p.get_output<int64_t>("neg"));
  });
  step("set flag", [&] {
    p.set_override("flag", false);
    return std::to_string(p.get_output<bool>("flag"));
  });
  step("set vec", [&] {
    p.set_override("vec", std::vector<double>{0.5, 1.5, 2.5});
    return join(p.get_output<std::vector<double>>("vec"));
  });
  step("set vec wrong size", [&] {
    p.set_override("vec", std::vector<double>{1, 2});
    return std::string("set");
  });
  step("set mat", [&] {
    double m[2][3] = {{9, 8, 7}, {6, 5, 4}};
    p.set_override("mat", m);
    return join(p.get_output<std::vector<std::vector<double>>>("mat")[0]);
  });
  step("set mat ragged", [&] {
    p.set_override("mat", std::vector<std::vector<double>>{{1, 2, 3}, {4}});
    return std::string("set");
  });
  step("set col", [&] {
    p.set_override("col", std::vector<std::vector<int>>{{-1}, {-2}, {-3}});
    return std::to_string(p.get_output<std::vector<std::vector<int>>>("col")[2][0]);
  });
  step("set limit", [&] {
    p.set_override("limit", 7);
    return std::to_string(p.get_output<int>("limit"));
  });
  step("set limit refused", [&] {
    p.set_override("limit", 12);
    return std::string("set");
  });
  step("limit after refusal", [&] { return std::to_string(p.get_output<int>("limit")); });
  step("strict set gain int", [&] {
    clnt.get_parameters(group, true).set_override("gain", 3);
    return std::string("set");
  });
  step("set unknown", [&] {
    p.set_override("nothere", 1.0);
    return std::string("set");
  });
  step("sub proxy", [&] {
    auto sub = p.get_parameters("sub");
    sub.set_override("deep", 0.75);
    return join({sub.get_output<double>("deep"), p.get_output<double>("sub.deep")});
  });
  step("signal proxy", [&] {
    auto s = p.get_signal<double>("gain");
    s.set_override(4.25);
    return join({s.get_output(), s.get_input()}) + " " + s.get_description();
  });
  step("from data scalar", [&] {
    float v = 1.25f;
    p.set_override_from_data_scalar("gain", ln::parameters::LN_SINGLE, &v);
    return join({p.get_output<double>("gain")});
  });
  step("from data vector", [&] {
    int32_t v[3] = {3, 2, 1};
    p.set_override_from_data_vector("vec", ln::parameters::LN_INT32, 3, v);
    return join(p.get_output<std::vector<double>>("vec"));
  });
  step("from data matrix column-major", [&] {
    double v[6] = {1, 4, 2, 5, 3, 6};
    p.set_override_from_data_matrix("mat", ln::parameters::LN_DOUBLE, 2, 3, v,
                                    ln::parameters::MatrixLayout::column_major);
    return rows(p.get_output<std::vector<std::vector<double>>>("mat"));
  });
  step("from data matrix stride", [&] {
    int16_t v[8] = {1, 2, 3, 99, 4, 5, 6, 99};
    p.set_override_from_data_matrix("mat", ln::parameters::LN_INT16, 2, 3, v, ln::parameters::MatrixLayout::row_major,
                                    8);
    return rows(p.get_output<std::vector<std::vector<double>>>("mat"));
  });
  step("into data matrix column-major", [&] {
    float v[6];
    p.get_into_data_matrix("mat", ln::parameters::LN_SINGLE, ln::parameters::ValueSource::output, 2, 3, v,
                           ln::parameters::MatrixLayout::column_major);
    return join({v[0], v[1], v[2], v[3], v[4], v[5]});
  });
  step("into data vector", [&] {
    int64_t v[3];
    p.get_into_data_vector("vec", ln::parameters::LN_INT64, ln::parameters::ValueSource::input, 3, v);
    return std::to_string(v[0]) + "," + std::to_string(v[2]);
  });
  step("into data vector wrong size", [&] {
    double v[4];
    p.get_into_data_vector("vec", ln::parameters::LN_DOUBLE, ln::parameters::ValueSource::input, 4, v);
    return std::string("read");
  });
  step("into data scalar", [&] {
    uint16_t v;
    p.get_into_data_scalar("count", ln::parameters::LN_UINT16, ln::parameters::ValueSource::input, &v);
    return std::to_string(v);
  });
  step("reset gain", [&] {
    p.reset_override("gain");
    p.set_override("count", 1);  // one more complete step of the provider
    return join({p.get_output<double>("gain")}) + " " + std::to_string(p.get_internal_value("gain").override_enabled);
  });
  step("unbound", [&] { return join({ln::parameters::parameter_proxy().get_input<double>("gain")}); });
  clnt.release_service(dict);
  clnt.release_service(query);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc == 3 && std::strcmp(argv[1], "provide") == 0) return provide(argv[2]);
  if (argc == 3 && std::strcmp(argv[1], "client") == 0) return client(argv[2]);
  std::fprintf(stderr, "usage: lnbt_parameters provide|client GROUP\n");
  return 2;
}
