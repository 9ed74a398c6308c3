// Mixed-language test: C++ caller of pytest/echo (service name argv[1]).
#include <cstdio>
#include <cstring>

#include "test_messages.h"

int main(int argc, char** argv) {
  ln::client clnt("cpp_echo_caller", argc, argv);
  ln::service* svc = clnt.get_service(argv[1], "pytest/echo", PYTEST_ECHO_SIGNATURE);
  pytest::echo_t data;
  std::memset(&data, 0, sizeof data);
  double values[3] = {1, 2, 3.5};
  char text[] = "hello from C++";
  pytest_point_t points[2] = {{1, 2}, {3, 4}};
  data.req.counter = 41;
  data.req.vec[1] = 2;
  data.req.values_len = 3;
  data.req.values = values;
  data.req.text_len = static_cast<uint32_t>(std::strlen(text));
  data.req.text = text;
  data.req.origin.x = 0.5;
  data.req.points_len = 2;
  data.req.points = points;
  svc->call(&data, 10);
  std::printf("counter=%u sum=%g values=", data.resp.counter, data.resp.sum);
  for (uint32_t i = 0; i < data.resp.values_len; ++i) std::printf("%s%g", i ? "," : "", data.resp.values[i]);
  std::printf(" text=%.*s points=", static_cast<int>(data.resp.text_len), data.resp.text);
  for (uint32_t i = 0; i < data.resp.points_len; ++i)
    std::printf("%s(%g,%g)", i ? "," : "", data.resp.points[i].x, data.resp.points[i].y);
  std::printf("\n");
  return 0;
}
