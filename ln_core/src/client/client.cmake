# The client library libln.so (ln.h's C API; the C++ API is header-only on
# top of it), its unit tests, and the cross-process topic tests in
# tests/topics. include() this file from ln_core/CMakeLists.txt after the
# targets ln_md, ln_protocol, ln_transport (transport.cmake) and, for the
# tests, ln_manager_core and ln_manager (manager.cmake) exist, and before
# cmake/ln_package_config.cmake (which exports `ln`).
#
# Targets:
#   ln_client_objects   the library's code, compiled once (PIC, hidden symbols)
#   ln                  libln.so.1 (SONAME libln.so.1, like LN 2.9); exports
#                       only the LN_API functions of ln.h
#   ln_client_unit_tests, ln_client_tests, ln_topic_tests and the programs
#   they start (if BUILD_TESTING)

find_package(Threads REQUIRED)

set(LN_CLIENT_DIR ${CMAKE_CURRENT_LIST_DIR})
get_filename_component(LN_CLIENT_SRC_DIR ${CMAKE_CURRENT_LIST_DIR} DIRECTORY)
get_filename_component(LN_CLIENT_ROOT_DIR ${LN_CLIENT_SRC_DIR} DIRECTORY)

add_library(ln_client_objects OBJECT
  ${LN_CLIENT_DIR}/client.cpp
  ${LN_CLIENT_DIR}/definitions.cpp
  ${LN_CLIENT_DIR}/event_loop.cpp
  ${LN_CLIENT_DIR}/events.cpp
  ${LN_CLIENT_DIR}/failure.cpp
  ${LN_CLIENT_DIR}/launch_options.cpp
  ${LN_CLIENT_DIR}/logger_data.cpp
  ${LN_CLIENT_DIR}/loggers.cpp
  ${LN_CLIENT_DIR}/manager_link.cpp
  ${LN_CLIENT_DIR}/multi_waiter.cpp
  ${LN_CLIENT_DIR}/name_mapping.cpp
  ${LN_CLIENT_DIR}/net.cpp
  ${LN_CLIENT_DIR}/peer.cpp
  ${LN_CLIENT_DIR}/ports.cpp
  ${LN_CLIENT_DIR}/remote.cpp
  ${LN_CLIENT_DIR}/service_logging.cpp
  ${LN_CLIENT_DIR}/services_glue.cpp
  ${LN_CLIENT_SRC_DIR}/capi/capi_client.cpp
  ${LN_CLIENT_SRC_DIR}/capi/capi_definitions.cpp
  ${LN_CLIENT_SRC_DIR}/capi/capi_dsa.cpp
  ${LN_CLIENT_SRC_DIR}/capi/capi_events.cpp
  ${LN_CLIENT_SRC_DIR}/capi/capi_introspection.cpp
  ${LN_CLIENT_SRC_DIR}/capi/capi_loggers.cpp
  ${LN_CLIENT_SRC_DIR}/capi/capi_topics.cpp
  ${LN_CLIENT_SRC_DIR}/capi/capi_services.cpp
  ${LN_CLIENT_SRC_DIR}/capi/capi_shm.cpp
)
set_target_properties(ln_client_objects PROPERTIES
  POSITION_INDEPENDENT_CODE ON
  CXX_VISIBILITY_PRESET hidden
  VISIBILITY_INLINES_HIDDEN ON)
target_include_directories(ln_client_objects PUBLIC ${LN_CLIENT_SRC_DIR} ${LN_CLIENT_ROOT_DIR}/include)
target_link_libraries(ln_client_objects PUBLIC ln_md ln_protocol ln_transport ln_services ln_crypto Threads::Threads)
ln_target_warnings(ln_client_objects)
if(BUILD_TESTING)
  # Fault injection for the multi-host tests (remote.cpp, inert unless
  # LN_CORE_TEST_UDP_FAULTS is set).
  target_compile_definitions(ln_client_objects PRIVATE LN_TEST_HOOKS)
endif()

add_library(ln SHARED $<TARGET_OBJECTS:ln_client_objects>)
set_target_properties(ln PROPERTIES
  OUTPUT_NAME ln
  VERSION 1.${LN_LIBRARY_VERSION}.0
  SOVERSION 1)
target_include_directories(ln PUBLIC
  $<BUILD_INTERFACE:${LN_CLIENT_ROOT_DIR}/include>
  $<INSTALL_INTERFACE:${CMAKE_INSTALL_INCLUDEDIR}>)
target_link_libraries(ln PRIVATE ln_md ln_protocol ln_transport ln_services ln_crypto Threads::Threads)
# Only ln.h's LN_API functions leave the library (libln.map; our code is also
# compiled with hidden visibility), and anything unresolved is an error at
# link time, not at a user's load time.
target_link_options(ln PRIVATE -Wl,--version-script=${LN_CLIENT_DIR}/libln.map -Wl,--no-undefined)
set_property(TARGET ln APPEND PROPERTY LINK_DEPENDS ${LN_CLIENT_DIR}/libln.map)

include(${LN_CLIENT_SRC_DIR}/parameters/parameters.cmake)

if(BUILD_TESTING)
  find_package(GTest REQUIRED)
  include(GoogleTest)

  # White-box tests of the pieces that need no manager.
  add_executable(ln_client_unit_tests
    ${LN_CLIENT_DIR}/launch_options_test.cpp
    ${LN_CLIENT_DIR}/logger_data_test.cpp
    ${LN_CLIENT_DIR}/multi_waiter_test.cpp
    ${LN_CLIENT_DIR}/net_test.cpp
    ${LN_CLIENT_DIR}/peer_test.cpp
    ${LN_CLIENT_DIR}/ports_test.cpp
    ${LN_CLIENT_DIR}/remote_test.cpp
    ${LN_CLIENT_DIR}/topic_stats_test.cpp)
  target_link_libraries(ln_client_unit_tests PRIVATE ln_client_objects GTest::gtest GTest::gtest_main)
  ln_target_warnings(ln_client_unit_tests)
  gtest_discover_tests(ln_client_unit_tests PROPERTIES TIMEOUT 60)

  if(TARGET ln_manager_core)
    # The public API of libln.so against an in-process manager.
    add_executable(ln_client_tests
      ${LN_CLIENT_DIR}/client_test.cpp
      ${LN_CLIENT_DIR}/events_test.cpp
      ${LN_CLIENT_DIR}/loggers_test.cpp
      ${LN_CLIENT_DIR}/service_logging_test.cpp
      ${LN_CLIENT_DIR}/topics_test.cpp)
    target_link_libraries(ln_client_tests PRIVATE ln ln_manager_core GTest::gtest GTest::gtest_main)
    target_include_directories(ln_client_tests PRIVATE ${LN_CLIENT_SRC_DIR})
    target_compile_definitions(ln_client_tests PRIVATE
      LN_TEST_MD_DIR="${LN_CLIENT_ROOT_DIR}/tests/topics/msgdefs")
    ln_target_warnings(ln_client_tests)
    gtest_discover_tests(ln_client_tests PROPERTIES TIMEOUT 120)

    include(${LN_CLIENT_ROOT_DIR}/tests/topics/topics.cmake)
    include(${LN_CLIENT_ROOT_DIR}/tests/remote/remote.cmake)
    include(${LN_CLIENT_ROOT_DIR}/tests/services/services.cmake)
    include(${LN_CLIENT_ROOT_DIR}/tests/introspection/introspection.cmake)
  endif()
endif()
