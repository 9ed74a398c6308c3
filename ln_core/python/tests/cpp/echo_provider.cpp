// Mixed-language test: C++ provider of pytest/echo (service name argv[1]):
// echoes counter + 1, sums values, doubles them, prefixes the text with
// "cpp: " and returns the points reversed. Serves until killed.
#include <cstdio>
#include <string>
#include <vector>

#include "test_messages.h"

class echo_provider : public pytest::echo_base {
 public:
  echo_provider(ln::client* clnt, const char* name) { register_echo(clnt, name); }

 private:
  int on_echo(ln::service_request& req, pytest::echo_t& data) override {
    values_.assign(data.req.values, data.req.values + data.req.values_len);
    double sum = 0;
    for (double& v : values_) {
      sum += v;
      v *= 2;
    }
    text_ = "cpp: " + std::string(data.req.text, data.req.text_len);
    points_.assign(data.req.points, data.req.points + data.req.points_len);
    std::vector<pytest_point_t> reversed(points_.rbegin(), points_.rend());
    points_ = reversed;
    data.resp.counter = data.req.counter + 1;
    data.resp.sum = sum + data.req.origin.x;
    data.resp.values_len = static_cast<uint32_t>(values_.size());
    data.resp.values = values_.data();
    data.resp.text_len = static_cast<uint32_t>(text_.size());
    data.resp.text = &text_[0];
    data.resp.points_len = static_cast<uint32_t>(points_.size());
    data.resp.points = points_.data();
    req.respond();
    return 0;
  }
  std::vector<double> values_;
  std::string text_;
  std::vector<pytest_point_t> points_;
};

int main(int argc, char** argv) {
  ln::client clnt("cpp_echo_provider", argc, argv);
  echo_provider provider(&clnt, argv[1]);
  std::printf("ready\n");
  std::fflush(stdout);
  for (;;) clnt.wait_and_handle_service_group_requests(NULL, 0.5);
}
