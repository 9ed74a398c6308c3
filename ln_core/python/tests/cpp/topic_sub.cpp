// Mixed-language test: C++ subscriber of pytest/all_types; prints N packets.
#include <cstdio>
#include <cstdlib>

#include "test_messages.h"

int main(int argc, char** argv) {
  ln::client clnt("cpp_topic_sub", argc, argv);
  const int n = std::atoi(argv[2]);
  ln::inport* port = clnt.subscribe(argv[1], PYTEST_ALL_TYPES_MD_NAME, -1, 16);
  std::printf("subscribed\n");
  std::fflush(stdout);
  pytest_all_types_t p;
  for (int got = 0; got < n;) {
    if (!port->read(&p, 10.0)) return 2;
    std::printf("u32=%u d=%g vec=%g,%g,%g name=%.8s corner1.x=%g i8=%d\n", p.u32, p.d, p.vec[0], p.vec[1], p.vec[2],
                p.name, p.corners[1].x, p.i8);
    ++got;
  }
  return 0;
}
