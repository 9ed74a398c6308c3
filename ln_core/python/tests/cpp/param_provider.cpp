// Parameter provider for test_mixed.py (LN 2.9's C++ API): block <group>
// with a scalar, a vector, a matrix, a bool and a checked integer; updates
// every millisecond until stdin closes, then prints what was in effect.
#include <ln/ln.h>
#include <ln/parameters.h>
#include <poll.h>
#include <unistd.h>

#include <cstdio>

int main(int argc, char** argv) {
  if (argc < 2) return 2;
  ln::client clnt("param_provider");
  double gain = 1.5, gain_out = 0;
  float vec[3] = {1, 2, 3}, vec_out[3] = {};
  int16_t mat[2][2] = {{1, -2}, {3, -4}}, mat_out[2][2] = {};
  bool flag = true, flag_out = false;
  int32_t limit = 5, limit_out = 0;
  ln::parameters::parameter_block block(&clnt, argv[1]);
  const bool ok =
      block.register_parameters(ln::parameters::port_description<double>("gain", "the gain", &gain, &gain_out),
                                ln::parameters::port_description<float[3]>("vec", "", &vec, &vec_out),
                                ln::parameters::port_description<int16_t[2][2]>("mat", "", &mat, &mat_out),
                                ln::parameters::port_description<bool>("flag", "", &flag, &flag_out),
                                ln::parameters::port_description<int32_t>(
                                    "limit", "below 100", &limit, &limit_out, [](int32_t& v) { return v < 100; },
                                    [](int32_t& v) { std::printf("applied limit %d\n", v), std::fflush(stdout); }));
  if (!ok) {
    std::printf("register failed: %s\n", block.error_message().c_str());
    return 1;
  }
  std::printf("ready\n");
  std::fflush(stdout);
  for (int i = 0; i < 20000; ++i) {
    block.update();
    pollfd in{0, POLLIN, 0};
    if (poll(&in, 1, 1) > 0) break;  // stdin closed (or written to): stop
  }
  std::printf("out gain=%g vec=%g,%g,%g mat=%d,%d,%d,%d flag=%d limit=%d\n", gain_out, vec_out[0], vec_out[1],
              vec_out[2], mat_out[0][0], mat_out[0][1], mat_out[1][0], mat_out[1][1], flag_out, limit_out);
  return 0;
}
