// Elevator controller (ln_spec 7.1), C++; interchangeable with elevator_control.py.
// Provides elevator03.prompt: drives the car to the requested floor with motor
// commands on elevator03.actors, following elevator03.sensors, and answers with the
// floor reached (error_code 1: invalid floor, no movement; 2: no sensor data or not
// arrived in time). Runs until SIGINT/SIGTERM.
//   LN_MANAGER=host:port elevator_control [--floors 10] [--move-timeout 30]
#include <algorithm>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>

#include "ln_messages.h"

namespace {
volatile std::sig_atomic_t stop_requested = 0;
void on_signal(int) { stop_requested = 1; }
constexpr double max_speed = 2.0;  // floors per second
constexpr double arrived = 0.005;  // floors
}  // namespace

class ElevatorServer : public elevator::request::elevator_call_base {
 public:
  ElevatorServer(ln::client& clnt, int floors, double move_timeout)
      : clnt_(clnt), floors_(floors), move_timeout_(move_timeout) {
    sensors_ = clnt.subscribe("elevator03.sensors", ELEVATOR_SENSORS_FLOOR_COUNT_MD_NAME);
    actors_ = clnt.publish("elevator03.actors", ELEVATOR_ACTORS_MOTOR_CONTROL_MD_NAME);
    register_elevator_call(&clnt_, "elevator03.prompt");
  }

  int on_elevator_call(ln::service_request& req, elevator::request::elevator_call_t& svc) override {
    const int target = svc.req.target_floor;
    std::string message;
    svc.resp.error_code = 0;
    if (target < 0 || target >= floors_) {
      svc.resp.reached_floor = -1;
      svc.resp.error_code = 1;
      message = "invalid floor " + std::to_string(target) + " (this building has floors 0.." +
                std::to_string(floors_ - 1) + ")";
    } else {
      elevator_sensors_floor_count_t state;
      bool have_state = false;
      const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(move_timeout_);
      bool done = false;
      while (!done && !stop_requested && std::chrono::steady_clock::now() < deadline) {
        if (sensors_->read(&state, 1.0)) have_state = true;
        if (!have_state) break;  // no simulator
        const double distance = target - state.position;
        if (std::fabs(distance) < arrived && state.at_floor) {
          command(0, 0.0);
          done = true;
        } else {
          // slow down near the target: arrive without overshooting
          command(distance > 0 ? 1 : -1, std::min(max_speed, std::max(0.05, 4.0 * std::fabs(distance))));
        }
      }
      if (!done) command(0, 0.0);
      svc.resp.reached_floor = have_state && state.at_floor ? state.floor : -1;
      if (svc.resp.reached_floor != target) {
        svc.resp.error_code = 2;
        message = have_state ? "did not reach floor " + std::to_string(target) : "no sensor data";
      }
      std::printf("elevator_control (C++): call for floor %d -> %d\n", target, svc.resp.reached_floor);
      std::fflush(stdout);
    }
    ln::string_buffer text(&svc.resp.error_message, message);  // must live until respond() returns
    req.respond();
    return 0;
  }

  void run() {
    while (!stop_requested) clnt_.wait_and_handle_service_group_requests(nullptr, 0.5);
    command(0, 0.0);
  }

 private:
  void command(int direction, double speed) {
    elevator_actors_motor_control_t packet;
    std::memset(&packet, 0, sizeof packet);
    packet.direction = static_cast<int8_t>(direction);
    packet.speed = speed;
    actors_->write(&packet);
  }

  ln::client& clnt_;
  int floors_;
  double move_timeout_;
  ln::inport* sensors_ = nullptr;
  ln::outport* actors_ = nullptr;
};

int main(int argc, char* argv[]) {
  int floors = 10;
  double move_timeout = 30.0;
  for (int i = 1; i + 1 < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--floors")
      floors = std::atoi(argv[++i]);
    else if (arg == "--move-timeout")
      move_timeout = std::atof(argv[++i]);
  }
  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);
  ln::client clnt("elevator_control", argc, argv);
  ElevatorServer server(clnt, floors, move_timeout);
  std::printf("elevator_control (C++) ready\n");
  std::fflush(stdout);
  server.run();
  std::printf("elevator_control (C++) stopped\n");
  return 0;
}
