# Topic data between two hosts: two network namespaces joined by a veth pair
# (the clients in them have different host ids), the manager and a publisher
# in one, a subscriber in the other; UDP by default, TCP with
# need_reliable_transport, publisher restarts, subscribers joining a running
# stream, datagrams lost/duplicated/reordered (a test-build hook, see
# remote_veth_test.py). The programs are written as for
# LN 2.9; remote_veth_test.py drives them (needs root for `ip netns`; skips
# with code 77 without it, fails when CI is set).
#
# include() after the targets ln, ln_manager and (inside ln_core)
# generate_ln_message_headers exist, with BUILD_TESTING on, e.g. from
# src/client/client.cmake next to tests/topics/topics.cmake:
#   include(${LN_CLIENT_ROOT_DIR}/tests/remote/remote.cmake)
#
# Targets: ln_remote_publisher, ln_remote_subscriber; test: remote_veth_transfer
# (label integration).

set(LN_REMOTE_TEST_DIR ${CMAKE_CURRENT_LIST_DIR})
if(NOT COMMAND generate_ln_message_headers)
  include(${LN_REMOTE_TEST_DIR}/../../cmake/ln_generate_headers.cmake)
endif()

generate_ln_message_headers(ln_remote_test_messages
  OUTPUT ln_remote_test/ln_messages.h
  MESSAGES remote/packet remote/big
  DIRECTORIES ${LN_REMOTE_TEST_DIR}/msgdefs)

foreach(program remote_publisher remote_subscriber)
  add_executable(ln_${program} ${LN_REMOTE_TEST_DIR}/${program}.cpp)
  target_link_libraries(ln_${program} PRIVATE ln ln_remote_test_messages_lib)
  ln_target_warnings(ln_${program})
endforeach()

find_package(Python3 COMPONENTS Interpreter)
if(Python3_Interpreter_FOUND)
  add_test(NAME remote_veth_transfer
           COMMAND ${Python3_EXECUTABLE} ${LN_REMOTE_TEST_DIR}/remote_veth_test.py
                   --manager $<TARGET_FILE:ln_manager>
                   --publisher $<TARGET_FILE:ln_remote_publisher>
                   --subscriber $<TARGET_FILE:ln_remote_subscriber>
                   --md-dir ${LN_REMOTE_TEST_DIR}/msgdefs)
  # The script bounds itself at 140 s and cleans up; RUN_SERIAL keeps the
  # timing of the UDP checks away from parallel load.
  set_tests_properties(remote_veth_transfer PROPERTIES
    TIMEOUT 190 SKIP_RETURN_CODE 77 LABELS integration RUN_SERIAL TRUE)
else()
  message(WARNING "remote_veth_transfer test not registered: no Python 3 interpreter")
endif()
