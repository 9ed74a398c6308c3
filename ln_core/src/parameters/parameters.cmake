# Parameters (ln/parameters_c.h; C++ ln/parameters.h, ln/parameter_client.h;
# Python on top): value forms, literal text and name patterns as a small
# library of their own, the provider and client parts inside libln.so.
# Included by src/client/client.cmake once ln_client_objects exists.
#
# Targets:
#   ln_paramcore              values, literal text, patterns (no libln)
#   ln_parameters_unit_tests  their GoogleTest tests (if BUILD_TESTING)
#   ln_parameters_tests       the C and C++ API against an in-process manager

set(LN_PARAMETERS_DIR ${CMAKE_CURRENT_LIST_DIR})

add_library(ln_paramcore STATIC
  ${LN_PARAMETERS_DIR}/literal.cpp
  ${LN_PARAMETERS_DIR}/pattern.cpp
  ${LN_PARAMETERS_DIR}/topic_layout.cpp
  ${LN_PARAMETERS_DIR}/values.cpp)
set_target_properties(ln_paramcore PROPERTIES POSITION_INDEPENDENT_CODE ON CXX_VISIBILITY_PRESET hidden)
target_include_directories(ln_paramcore PUBLIC ${LN_CLIENT_SRC_DIR})
ln_target_warnings(ln_paramcore)

target_sources(ln_client_objects PRIVATE
  ${LN_PARAMETERS_DIR}/diagnostics.cpp
  ${LN_PARAMETERS_DIR}/provider.cpp
  ${LN_PARAMETERS_DIR}/remote.cpp
  ${LN_CLIENT_SRC_DIR}/capi/capi_parameters.cpp)
target_link_libraries(ln_client_objects PUBLIC ln_paramcore)
target_link_libraries(ln PRIVATE ln_paramcore)

# The structs of the ln/parameters/* services, written by our ln_generate.
if(NOT COMMAND generate_ln_message_headers)
  include(${LN_CLIENT_ROOT_DIR}/cmake/ln_generate_headers.cmake)
endif()
generate_ln_message_headers(ln_client_objects
  OUTPUT parameters_generated/ln_parameter_messages.h
  MESSAGES ln/parameters/query ln/parameters/query_dict ln/parameters/override_dict_single
           ln/parameters/request_parameter_topic
  DIRECTORIES ${LN_CLIENT_ROOT_DIR}/share/message_definitions)

if(BUILD_TESTING)
  find_package(GTest REQUIRED)
  include(GoogleTest)
  add_executable(ln_parameters_unit_tests
    ${LN_PARAMETERS_DIR}/literal_test.cpp
    ${LN_PARAMETERS_DIR}/pattern_test.cpp
    ${LN_PARAMETERS_DIR}/topic_layout_test.cpp
    ${LN_PARAMETERS_DIR}/values_test.cpp)
  target_link_libraries(ln_parameters_unit_tests PRIVATE ln_paramcore GTest::gtest GTest::gtest_main)
  ln_target_warnings(ln_parameters_unit_tests)
  gtest_discover_tests(ln_parameters_unit_tests PROPERTIES TIMEOUT 60)

  if(TARGET ln_manager_core)
    add_executable(ln_parameters_tests ${LN_PARAMETERS_DIR}/parameters_api_test.cpp)
    target_link_libraries(ln_parameters_tests PRIVATE ln ln_manager_core GTest::gtest GTest::gtest_main)
    target_include_directories(ln_parameters_tests PRIVATE ${LN_CLIENT_SRC_DIR}
                               ${CMAKE_CURRENT_BINARY_DIR}/parameters_generated)
    add_dependencies(ln_parameters_tests ln_client_objects)
    target_compile_definitions(ln_parameters_tests PRIVATE
      LN_TEST_MD_DIR="${LN_CLIENT_ROOT_DIR}/share/message_definitions")
    ln_target_warnings(ln_parameters_tests)
    gtest_discover_tests(ln_parameters_tests PROPERTIES TIMEOUT 120)
  endif()
endif()
