"""Acceptance: the elevator example's message definitions (ln_spec.md 7.1,
ln_core/examples/elevator/msgdefs) through our ln_generate, used from C and
C++ with -Wall -Wextra -Werror against ln_core's own include directory.

(The same definitions are also in the differential comparison with LN 2.9,
set "elevator" of test_ln_generate_differential.py.)
"""

from __future__ import annotations

import ln_diff_support as support
import pytest

NAMES = ["elevator/sensors/floor_count", "elevator/actors/motor_control", "elevator/request/elevator_call"]

C_SOURCE = r"""
#include <stddef.h>
#include <string.h>
#include "elevator_messages.h"

/* packed layouts: no padding anywhere */
_Static_assert(sizeof(elevator_sensors_floor_count_t) == 8 + 8 + 4 + 1, "floor_count size");
_Static_assert(sizeof(elevator_actors_motor_control_t) == 1 + 8, "motor_control size");
_Static_assert(offsetof(elevator_actors_motor_control_t, speed) == 1, "speed directly after direction");
_Static_assert(sizeof(((elevator_request_elevator_call_t*)0)->req) == 4, "request size");
_Static_assert(sizeof(((elevator_request_elevator_call_t*)0)->resp) == 4 + 4 + 4 + sizeof(char*), "response size");

static const char* const md_names[] = {
    ELEVATOR_SENSORS_FLOOR_COUNT_MD_NAME,
    ELEVATOR_ACTORS_MOTOR_CONTROL_MD_NAME,
    ELEVATOR_REQUEST_ELEVATOR_CALL_MD_NAME,
};

int fill_elevator_messages(double now, char* message, size_t* total_size);

int fill_elevator_messages(double now, char* message, size_t* total_size) {
    elevator_sensors_floor_count_t sensors;
    elevator_actors_motor_control_t motor;
    elevator_request_elevator_call_t call;
    struct elevator_request_elevator_call_request_t request;
    struct elevator_request_elevator_call_response_t response;

    memset(&sensors, 0, sizeof sensors);
    sensors.time = now;
    sensors.position = 2.5;
    sensors.floor = 2;
    sensors.at_floor = 0;

    motor.direction = -1;
    motor.speed = 0.5;

    request.target_floor = 3;
    call.req = request;
    response.reached_floor = 3;
    response.error_code = 0;
    response.error_message = message;
    response.error_message_len = (uint32_t)strlen(message);
    call.resp = response;

    *total_size = sizeof sensors + sizeof motor + sizeof call + sizeof md_names;
    return call.resp.reached_floor == call.req.target_floor
        && strcmp(elevator_request_elevator_call_signature, ELEVATOR_REQUEST_ELEVATOR_CALL_SIGNATURE) == 0;
}
"""

CXX_SOURCE = r"""
#include <cstddef>
#include <cstring>
#include "elevator_messages.h"

static_assert(sizeof(elevator_sensors_floor_count_t) == 21, "floor_count size");
static_assert(sizeof(elevator::request::elevator_call_t) == 4 + 12 + sizeof(char*), "service size");

// The controller of the tutorial: provides the service through the generated base class.
class ElevatorServer : public elevator::request::elevator_call_base {
public:
    explicit ElevatorServer(ln::client* clnt) { register_elevator_call(clnt, "elevator03.prompt"); }
    int on_elevator_call(ln::service_request& req, elevator::request::elevator_call_t& data) override {
        data.resp.reached_floor = data.req.target_floor;
        data.resp.error_code = 0;
        static char ok[] = "ok";
        data.resp.error_message = ok;
        data.resp.error_message_len = 2;
        req.respond();
        return 0;
    }
};

std::size_t use_elevator_types(double now);

std::size_t use_elevator_types(double now) {
    elevator_sensors_floor_count_t sensors{};
    sensors.time = now;
    sensors.floor = 1;
    elevator_actors_motor_control_t motor{};
    motor.direction = 1;
    motor.speed = 1.0;
    elevator::request::elevator_call_t call{};
    call.req.target_floor = 4;
    elevator::request::elevator_call_t::request_t request = call.req;
    elevator::request::elevator_call_t::response_t response = call.resp;
    return sizeof sensors + sizeof motor + sizeof request + sizeof response
        + std::strlen(ELEVATOR_REQUEST_ELEVATOR_CALL_MD_NAME) + std::strlen(elevator_request_elevator_call_signature);
}
"""


@pytest.fixture
def elevator_header(our_tools, tool_env, work_dir):
    assert support.ELEVATOR_MD_DIR.is_dir(), f"missing {support.ELEVATOR_MD_DIR}"
    out = work_dir / "elevator_messages.h"
    r = support.run(
        [our_tools.ln_generate, "--md-dir", support.ELEVATOR_MD_DIR, "-o", out, *NAMES], tool_env, cwd=work_dir
    )
    assert r.returncode == 0, f"ln_generate failed on the elevator definitions\n{r.describe()}"
    return out


def test_elevator_names_and_signature(elevator_header):
    text = elevator_header.read_text()
    for macro in (
        "ELEVATOR_SENSORS_FLOOR_COUNT_MD_NAME",
        "ELEVATOR_ACTORS_MOTOR_CONTROL_MD_NAME",
        "ELEVATOR_REQUEST_ELEVATOR_CALL_MD_NAME",
    ):
        value = support.string_macro(text, macro)
        assert value and "|" in value and len(value.split("|")[1]) == 64, f"{macro} = {value!r}"
    assert (
        support.string_macro(text, "ELEVATOR_REQUEST_ELEVATOR_CALL_SIGNATURE")
        == "int32_t 4 1|int32_t 4 1,int32_t 4 1,uint32_t 4 1,char* 1 1"
    )


def _compile(compiler, std, source_name, source, header, work_dir, env):
    src = work_dir / source_name
    src.write_text(source)
    include = support.OUR_INCLUDE_DIR
    if not (include / "ln" / "ln.h").is_file():
        pytest.fail(
            f"ln_core's {include}/ln/ln.h does not exist yet (the generated header includes <ln/ln.h>)", pytrace=False
        )
    r = support.run(
        [
            compiler,
            std,
            "-Wall",
            "-Wextra",
            "-Werror",
            "-c",
            "-I",
            header.parent,
            "-I",
            include,
            src,
            "-o",
            work_dir / (source_name + ".o"),
        ],
        env,
        timeout=support.COMPILE_TIMEOUT,
    )
    assert r.returncode == 0, (
        f"compiling {source_name} ({std}) against the generated elevator header and {include} failed\n{r.describe()}"
    )


def test_elevator_header_in_c(elevator_header, c_compiler, work_dir, tool_env):
    _compile(c_compiler, "-std=c11", "elevator_use.c", C_SOURCE, elevator_header, work_dir, tool_env)


def test_elevator_header_in_cxx(elevator_header, cxx_compiler, work_dir, tool_env):
    _compile(cxx_compiler, "-std=c++17", "elevator_use.cpp", CXX_SOURCE, elevator_header, work_dir, tool_env)
