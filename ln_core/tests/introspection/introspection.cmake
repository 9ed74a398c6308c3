# Introspection across processes: ln_list_topics/_clients/_services and
# ln_get_manager_status (C and C++ API) with publishers, subscribers and
# providers in other processes, topic rates, and publisher availability
# handlers. Included by src/client/client.cmake after tests/topics and
# tests/services, whose programs it starts.

add_executable(ln_introspection_tests ${CMAKE_CURRENT_LIST_DIR}/introspection_process_test.cpp)
target_link_libraries(ln_introspection_tests PRIVATE ln ln_manager_core GTest::gtest GTest::gtest_main)
target_include_directories(ln_introspection_tests PRIVATE ${LN_CLIENT_SRC_DIR})
target_compile_definitions(ln_introspection_tests PRIVATE
  LN_TEST_MD_DIR="${LN_TOPICS_TEST_DIR}/msgdefs"
  LN_TEST_SERVICES_MD_DIR="${LN_SERVICES_TEST_DIR}/msgdefs"
  LN_TEST_PUBLISHER="$<TARGET_FILE:ln_test_publisher>"
  LN_TEST_SUBSCRIBER="$<TARGET_FILE:ln_test_subscriber>"
  LN_SVC_PROVIDER="$<TARGET_FILE:ln_svc_provider>")
add_dependencies(ln_introspection_tests ln_test_publisher ln_test_subscriber ln_svc_provider)
ln_target_warnings(ln_introspection_tests)
gtest_discover_tests(ln_introspection_tests PROPERTIES TIMEOUT 120)
