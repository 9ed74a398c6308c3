// Elevator hardware simulator (ln_spec 7.1), C++; interchangeable with elevator_sim.py.
// Reads motor commands from elevator03.actors without blocking, integrates the car
// position at a fixed rate and publishes elevator03.sensors every step, stamped with
// the simulation time. Runs until SIGINT/SIGTERM or --duration seconds.
//   LN_MANAGER=host:port elevator_sim [--floors 10] [--rate 50] [--duration 0]
#include <algorithm>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <thread>

#include "ln_messages.h"

namespace {
volatile std::sig_atomic_t stop_requested = 0;
void on_signal(int) { stop_requested = 1; }
constexpr double at_floor_tolerance = 1e-3;  // |position - floor| below this is level
constexpr double snap_distance = 0.02;       // a stopped car this close is pulled level (brakes)
}  // namespace

int main(int argc, char* argv[]) {
  int floors = 10;
  double rate = 50.0, duration = 0.0;
  for (int i = 1; i + 1 < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--floors")
      floors = std::atoi(argv[++i]);
    else if (arg == "--rate")
      rate = std::atof(argv[++i]);
    else if (arg == "--duration")
      duration = std::atof(argv[++i]);
  }
  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);

  ln::client clnt("elevator_sim", argc, argv);
  ln::outport* sensors = clnt.publish("elevator03.sensors", ELEVATOR_SENSORS_FLOOR_COUNT_MD_NAME);
  ln::inport* actors = clnt.subscribe("elevator03.actors", ELEVATOR_ACTORS_MOTOR_CONTROL_MD_NAME);
  std::printf("elevator_sim (C++) ready: %d floors, %.0f Hz\n", floors, rate);
  std::fflush(stdout);

  using clock = std::chrono::steady_clock;
  const auto dt = std::chrono::duration<double>(1.0 / rate);
  auto next_step = clock::now();
  const auto end =
      duration > 0 ? next_step + std::chrono::duration_cast<clock::duration>(std::chrono::duration<double>(duration))
                   : clock::time_point::max();
  double position = 0.0, sim_time = 0.0, speed = 0.0;
  int direction = 0;
  while (!stop_requested && clock::now() < end) {
    elevator_actors_motor_control_t command;
    if (actors->read(&command, false)) {
      direction = std::max(-1, std::min(1, static_cast<int>(command.direction)));
      speed = std::max(0.0, command.speed);
    }
    position = std::min(std::max(position + direction * speed * dt.count(), 0.0), floors - 1.0);
    const double nearest = std::round(position);
    if (direction == 0 && std::fabs(position - nearest) < snap_distance) position = nearest;
    sim_time += dt.count();
    elevator_sensors_floor_count_t packet;
    std::memset(&packet, 0, sizeof packet);
    packet.time = sim_time;
    packet.position = position;
    packet.floor = static_cast<int32_t>(nearest);
    packet.at_floor = std::fabs(position - nearest) < at_floor_tolerance ? 1 : 0;
    sensors->write(&packet, sim_time);
    next_step += std::chrono::duration_cast<clock::duration>(dt);
    std::this_thread::sleep_until(next_step);
  }
  std::printf("elevator_sim (C++) stopped at position %.3f\n", position);
  return 0;
}
