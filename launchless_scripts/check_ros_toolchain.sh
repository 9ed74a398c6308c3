#!/usr/bin/env bash
# Diagnostic, not run by test.sh: proves that the project venv's ROS 2 Jazzy (PyPI wheels) builds and
# runs custom interfaces, i.e. that setup.sh's fixes from shared/docs/ros2_from_pypi.md Q1 work.
# In a throw-away workspace under /tmp it colcon-builds an interface package (.msg + .srv) and a C
# program on rcl, then uses the interface from rclpy (pub/sub + service) and runs the C program.
# Usage: bash launchless_scripts/check_ros_toolchain.sh      (about a minute; prints "ROS toolchain OK")
set -euo pipefail

HERE=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
timeout 4000 bash "$HERE/setup.sh" --no-build
. "$HERE/env.sh"
WS=$(mktemp -d /tmp/ln_core_ros_check.XXXXXX)
trap 'rm -rf "$WS"' EXIT
echo "check_ros_toolchain: workspace $WS"

# write_package_xml DIR NAME XML...: an ament_cmake package.xml with these further elements
write_package_xml() {
  local dir=$1 name=$2
  shift 2
  {
    echo '<?xml version="1.0"?>'
    echo '<package format="3">'
    echo "  <name>$name</name><version>0.0.1</version><description>check</description>"
    echo '  <maintainer email="x@example.invalid">x</maintainer><license>Apache-2.0</license>'
    echo '  <buildtool_depend>ament_cmake</buildtool_depend>'
    printf '  %s\n' "$@"
    echo '  <export><build_type>ament_cmake</build_type></export>'
    echo '</package>'
  } > "$dir/package.xml"
}

timeout 60 colcon --help > /dev/null
timeout 60 python -c "import rclpy; from std_msgs.msg import Header; print('rclpy', rclpy.__file__)"

P=$WS/src/lncheck_interfaces
mkdir -p "$P/msg" "$P/srv"
printf 'std_msgs/Header header\nuint32 seq\nfloat64[3] position\nstring label\nfloat32[] values\n' > "$P/msg/Sample.msg"
printf 'float32[] values\nstring op\n---\nfloat64 result\nbool ok\nstring message\n' > "$P/srv/Compute.srv"
cat > "$P/CMakeLists.txt" <<'EOF'
cmake_minimum_required(VERSION 3.8)
project(lncheck_interfaces)
find_package(ament_cmake REQUIRED)
find_package(rosidl_default_generators REQUIRED)
find_package(std_msgs REQUIRED)
rosidl_generate_interfaces(${PROJECT_NAME} "msg/Sample.msg" "srv/Compute.srv" DEPENDENCIES std_msgs)
ament_export_dependencies(rosidl_default_runtime)
ament_package()
EOF
write_package_xml "$P" lncheck_interfaces \
  '<buildtool_depend>rosidl_default_generators</buildtool_depend>' '<depend>std_msgs</depend>' \
  '<exec_depend>rosidl_default_runtime</exec_depend>' \
  '<member_of_group>rosidl_interface_packages</member_of_group>'

# A C program on rcl (no rclcpp on PyPI): needs libpython and DT_RPATH, and the libtinyxml2 fix.
C=$WS/src/lncheck_c
mkdir -p "$C/src"
cat > "$C/src/c_pub.c" <<'EOF'
#include <stdio.h>
#include <rcl/rcl.h>
#include <lncheck_interfaces/msg/sample.h>
#define CHECK(x) do { if ((x) != RCL_RET_OK) { fprintf(stderr, "%s failed\n", #x); return 1; } } while (0)
int main(void) {
  rcl_context_t ctx = rcl_get_zero_initialized_context();
  rcl_init_options_t io = rcl_get_zero_initialized_init_options();
  CHECK(rcl_init_options_init(&io, rcl_get_default_allocator()));
  CHECK(rcl_init(0, NULL, &io, &ctx));
  rcl_node_t node = rcl_get_zero_initialized_node();
  rcl_node_options_t no = rcl_node_get_default_options();
  CHECK(rcl_node_init(&node, "lncheck_c", "", &ctx, &no));
  rcl_publisher_t pub = rcl_get_zero_initialized_publisher();
  rcl_publisher_options_t po = rcl_publisher_get_default_options();
  CHECK(rcl_publisher_init(&pub, &node, ROSIDL_GET_MSG_TYPE_SUPPORT(lncheck_interfaces, msg, Sample), "lncheck_c", &po));
  lncheck_interfaces__msg__Sample msg;
  lncheck_interfaces__msg__Sample__init(&msg);
  msg.seq = 7;
  CHECK(rcl_publish(&pub, &msg, NULL));
  lncheck_interfaces__msg__Sample__fini(&msg);
  CHECK(rcl_publisher_fini(&pub, &node));
  CHECK(rcl_node_fini(&node));
  CHECK(rcl_shutdown(&ctx));
  printf("c_pub: published one lncheck_interfaces/msg/Sample through rcl\n");
  return 0;
}
EOF
cat > "$C/CMakeLists.txt" <<'EOF'
cmake_minimum_required(VERSION 3.8)
project(lncheck_c C)
find_package(ament_cmake REQUIRED)
find_package(rcl REQUIRED)
find_package(lncheck_interfaces REQUIRED)
find_package(Python3 REQUIRED COMPONENTS Interpreter Development.Embed)  # Interpreter: the venv's libpython
add_executable(c_pub src/c_pub.c)
target_link_libraries(c_pub rcl::rcl ${lncheck_interfaces_TARGETS} Python3::Python)
file(GLOB ROS_WHEEL_LIBS "$ENV{VIRTUAL_ENV}/lib/python3.11/site-packages/ros_*.libs")
set_target_properties(c_pub PROPERTIES INSTALL_RPATH "$ENV{VIRTUAL_ENV}/lib;${ROS_WHEEL_LIBS}")
target_link_options(c_pub PRIVATE "-Wl,--disable-new-dtags" "-Wl,--no-as-needed")
install(TARGETS c_pub DESTINATION lib/${PROJECT_NAME})
ament_package()
EOF
write_package_xml "$C" lncheck_c '<depend>rcl</depend>' '<depend>lncheck_interfaces</depend>'

cat > "$WS/check.py" <<'EOF'
import time
import rclpy
from rclpy.serialization import serialize_message, deserialize_message
from lncheck_interfaces.msg import Sample
from lncheck_interfaces.srv import Compute

msg = Sample(seq=3, position=[1.0, 2.0, 3.5], label="hi", values=[0.5, 1.5])
msg.header.frame_id = "f"
back = deserialize_message(serialize_message(msg), Sample)
assert back.seq == 3 and list(back.position) == [1.0, 2.0, 3.5] and back.label == "hi", back

rclpy.init()
node = rclpy.create_node("lncheck_py")
got = []
node.create_subscription(Sample, "lncheck", got.append, 10)
pub = node.create_publisher(Sample, "lncheck", 10)
def compute(req, resp):
    resp.result, resp.ok = float(sum(req.values)), True
    return resp
node.create_service(Compute, "lncheck_compute", compute)
cli = node.create_client(Compute, "lncheck_compute")
deadline = time.monotonic() + 20
while not got and time.monotonic() < deadline:     # publish until discovery has matched
    pub.publish(msg)
    rclpy.spin_once(node, timeout_sec=0.1)
assert got and got[0].label == "hi" and list(got[0].values) == [0.5, 1.5], "no Sample received in 20 s"
assert cli.wait_for_service(timeout_sec=20), "service not found in 20 s"
future = cli.call_async(Compute.Request(values=[1.5, 2.5, 3.0], op="sum"))
rclpy.spin_until_future_complete(node, future, timeout_sec=20)
assert future.done() and future.result().ok and future.result().result == 7.0, "service call failed"
node.destroy_node()
rclpy.shutdown()
print("check.py: serialize round trip, pub/sub and service with lncheck_interfaces OK")
EOF

cd "$WS"
start=$SECONDS
timeout 900 colcon build --event-handlers desktop_notification- console_cohesion+ --cmake-args -G Ninja > build.log 2>&1 \
  || { tail -n 80 build.log; echo "check_ros_toolchain: colcon build FAILED" >&2; exit 1; }
echo "check_ros_toolchain: colcon build of the two packages took $((SECONDS - start)) s"
set +u; . install/setup.bash; set -u
timeout 120 python check.py
timeout 60 install/lncheck_c/lib/lncheck_c/c_pub
echo "ROS toolchain OK"
