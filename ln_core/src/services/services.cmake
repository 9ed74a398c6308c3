# The service data path: signature compiler, flat marshalling, call frames,
# provider dispatch (groups, thread pools) and caller call state.
# include() this file from ln_core/CMakeLists.txt after ln_md and ln_generate
# are defined. Consumers include headers as "services/dispatch.hpp" etc.
#
# Targets:
#   ln_services          static, position-independent library
#   services_unit_tests  GoogleTest tests (if BUILD_TESTING)
#   service_rtt_bench    round-trip micro-benchmark, one JSON line per result

set(LN_SERVICES_SOURCE_DIR ${CMAKE_CURRENT_LIST_DIR})
get_filename_component(LN_SERVICES_INCLUDE_DIR ${CMAKE_CURRENT_LIST_DIR} DIRECTORY)
find_package(Threads REQUIRED)

add_library(ln_services STATIC
  ${LN_SERVICES_SOURCE_DIR}/signature.cpp
  ${LN_SERVICES_SOURCE_DIR}/marshal.cpp
  ${LN_SERVICES_SOURCE_DIR}/call_frames.cpp
  ${LN_SERVICES_SOURCE_DIR}/socket_io.cpp
  ${LN_SERVICES_SOURCE_DIR}/dispatch.cpp
  ${LN_SERVICES_SOURCE_DIR}/call_state.cpp
  ${LN_SERVICES_SOURCE_DIR}/call_log.cpp)
set_target_properties(ln_services PROPERTIES POSITION_INDEPENDENT_CODE ON)
target_compile_features(ln_services PUBLIC cxx_std_17)
target_include_directories(ln_services PUBLIC $<BUILD_INTERFACE:${LN_SERVICES_INCLUDE_DIR}>)
target_link_libraries(ln_services PUBLIC ln_md Threads::Threads)
ln_target_warnings(ln_services)

# Headers of the test definitions (testdata/md), written by our ln_generate.
set(LN_SERVICES_TEST_MDS
  tests/time_service svc_test/everything svc_test/now svc_test/fire svc_test/ping svc_test/add svc_test/echo)
set(LN_SERVICES_GENERATED_DIR ${CMAKE_CURRENT_BINARY_DIR}/services_generated)
set(LN_SERVICES_GENERATED_HEADER ${LN_SERVICES_GENERATED_DIR}/services_test_messages.h)
file(GLOB_RECURSE LN_SERVICES_TEST_MD_FILES ${LN_SERVICES_SOURCE_DIR}/testdata/md/*)
add_custom_command(
  OUTPUT ${LN_SERVICES_GENERATED_HEADER}
  COMMAND ${CMAKE_COMMAND} -E make_directory ${LN_SERVICES_GENERATED_DIR}
  COMMAND ln_generate -f --md-dir ${LN_SERVICES_SOURCE_DIR}/testdata/md -o ${LN_SERVICES_GENERATED_HEADER}
          ${LN_SERVICES_TEST_MDS}
  DEPENDS ln_generate ${LN_SERVICES_TEST_MD_FILES}
  COMMENT "ln_generate services_test_messages.h"
  VERBATIM)
add_custom_target(ln_services_test_messages DEPENDS ${LN_SERVICES_GENERATED_HEADER})

add_executable(service_rtt_bench ${LN_SERVICES_SOURCE_DIR}/service_rtt_bench.cpp)
target_link_libraries(service_rtt_bench PRIVATE ln_services ln_protocol)
target_include_directories(service_rtt_bench PRIVATE ${LN_SERVICES_GENERATED_DIR})
add_dependencies(service_rtt_bench ln_services_test_messages)
ln_target_warnings(service_rtt_bench)

if(BUILD_TESTING)
  find_package(GTest REQUIRED)
  include(GoogleTest)
  add_executable(services_unit_tests
    ${LN_SERVICES_SOURCE_DIR}/signature_test.cpp
    ${LN_SERVICES_SOURCE_DIR}/marshal_test.cpp
    ${LN_SERVICES_SOURCE_DIR}/generated_structs_test.cpp
    ${LN_SERVICES_SOURCE_DIR}/call_frames_test.cpp
    ${LN_SERVICES_SOURCE_DIR}/dispatch_test.cpp
    ${LN_SERVICES_SOURCE_DIR}/call_state_test.cpp)
  target_link_libraries(services_unit_tests PRIVATE ln_services GTest::gtest GTest::gtest_main)
  target_include_directories(services_unit_tests PRIVATE ${LN_SERVICES_GENERATED_DIR})
  add_dependencies(services_unit_tests ln_services_test_messages)
  ln_target_warnings(services_unit_tests)
  gtest_discover_tests(services_unit_tests PROPERTIES TIMEOUT 120)
endif()
