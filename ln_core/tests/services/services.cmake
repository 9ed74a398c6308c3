# Cross-process service tests: providers written as for LN 2.9 (C and C++,
# headers from generate_ln_message_headers) started by the gtest driver
# ln_service_tests, which calls them through the C and C++ APIs against a
# manager in its own process (services_process_test.cpp: calls, errors,
# pools, TCP; services_api_test.cpp: callv/respondv, provider descriptors,
# pool scheduling, introspection, name mapping, error texts). Included by
# src/client/client.cmake.

set(LN_SERVICES_TEST_DIR ${CMAKE_CURRENT_LIST_DIR})
if(NOT COMMAND generate_ln_message_headers)
  include(${LN_CLIENT_ROOT_DIR}/cmake/ln_generate_headers.cmake)
endif()

generate_ln_message_headers(ln_svc_process_messages
  OUTPUT ln_svc_process/ln_messages.h
  MESSAGES svc/test
  DIRECTORIES ${LN_SERVICES_TEST_DIR}/msgdefs)

foreach(program ln_svc_provider.c ln_svc_provider_cpp.cpp ln_svc_caller.c)
  get_filename_component(name ${program} NAME_WE)
  add_executable(${name} ${LN_SERVICES_TEST_DIR}/${program})
  target_link_libraries(${name} PRIVATE ln ln_svc_process_messages_lib Threads::Threads)
  ln_target_warnings(${name})
endforeach()

add_executable(ln_service_tests ${LN_SERVICES_TEST_DIR}/services_process_test.cpp
                                ${LN_SERVICES_TEST_DIR}/services_api_test.cpp)
target_link_libraries(ln_service_tests PRIVATE ln ln_manager_core ln_svc_process_messages_lib
                      GTest::gtest GTest::gtest_main)
target_include_directories(ln_service_tests PRIVATE ${LN_CLIENT_SRC_DIR})
target_compile_definitions(ln_service_tests PRIVATE
  LN_TEST_MD_DIR="${LN_SERVICES_TEST_DIR}/msgdefs"
  LN_SVC_PROVIDER="$<TARGET_FILE:ln_svc_provider>"
  LN_SVC_PROVIDER_CPP="$<TARGET_FILE:ln_svc_provider_cpp>"
  LN_SVC_CALLER="$<TARGET_FILE:ln_svc_caller>"
  LN_MANAGER_PROGRAM="$<TARGET_FILE:ln_manager>")
add_dependencies(ln_service_tests ln_svc_provider ln_svc_provider_cpp ln_svc_caller ln_manager)
ln_target_warnings(ln_service_tests)
gtest_discover_tests(ln_service_tests PROPERTIES TIMEOUT 120)
