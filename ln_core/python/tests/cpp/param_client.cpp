// Parameter client for test_mixed.py (LN 2.9's C++ API): reads and
// overrides the parameters of a Python provider's block <group> and prints
// what it sees, one line per step ("<what>: <result>").
#include <ln/ln.h>
#include <ln/parameter_client.h>

#include <cstdio>
#include <functional>
#include <string>
#include <vector>

static void step(const char* what, const std::function<std::string()>& body) {
  try {
    std::printf("%s: %s\n", what, body().c_str());
  } catch (const std::exception& e) {
    std::printf("%s: error %s\n", what, e.what());
  }
}

int main(int argc, char** argv) {
  if (argc < 2) return 2;
  ln::client clnt("param_client");
  auto params = clnt.get_parameters(argv[1]);
  step("gain", [&] { return std::to_string(params.get_output<double>("gain")); });
  step("n", [&] { return std::to_string(params.get_input<long>("n")); });
  step("mat", [&] {
    auto m = params.get_input<std::vector<std::vector<int>>>("mat");
    return std::to_string(m.size()) + "x" + std::to_string(m[0].size()) + " " + std::to_string(m[1][2]);
  });
  step("flag", [&] { return std::string(params.get_input<bool>("flag") ? "true" : "false"); });
  step("description", [&] { return params.get_description("gain"); });
  step("set gain", [&] {
    params.set_override("gain", 2.5);
    return std::to_string(params.get_output<double>("gain"));
  });
  step("set vec", [&] {
    params.set_override("vec", std::vector<double>{4, 5, 6});
    return std::to_string(params.get_output<std::vector<double>>("vec")[2]);
  });
  step("set n", [&] {
    params.set_override("n", 2.9);
    return std::to_string(params.get_output<int>("n"));
  });
  step("set mat", [&] {
    params.set_override("mat", std::vector<std::vector<int>>{{9, 8, 7}, {6, 5, 4}});
    return std::to_string(params.get_output<std::vector<std::vector<int>>>("mat")[1][0]);
  });
  step("wrong shape", [&] {
    params.set_override("vec", std::vector<double>{1, 2});
    return std::string("set");
  });
  step("too big", [&] {
    params.set_override("small", 1000);
    return std::string("set");
  });
  step("unknown", [&] { return std::to_string(params.get_input<double>("nothere")); });
  return 0;
}
