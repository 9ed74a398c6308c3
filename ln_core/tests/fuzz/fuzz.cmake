# The fuzz suite (fuzz.hpp): bounded, seeded targets for what other
# processes send or write -- manager frames, service frames, topic data from
# other hosts, definition texts, .lnc files. Each ends with a check that a
# normal client is still served. CI runs it (here and in the sanitizer
# build); LN_FUZZ_SEED, LN_FUZZ_ROUNDS and LN_FUZZ_SECONDS make longer runs.
set(LN_FUZZ_DIR ${CMAKE_CURRENT_LIST_DIR})
add_executable(ln_fuzz_tests
  ${LN_FUZZ_DIR}/manager_frames_fuzz_test.cpp
  ${LN_FUZZ_DIR}/service_frames_fuzz_test.cpp
  ${LN_FUZZ_DIR}/topic_receiver_fuzz_test.cpp
  ${LN_FUZZ_DIR}/definition_texts_fuzz_test.cpp
  ${LN_FUZZ_DIR}/lnc_fuzz_test.cpp)
target_link_libraries(ln_fuzz_tests PRIVATE ln_client_objects ln_manager_core ln_services GTest::gtest GTest::gtest_main)
target_include_directories(ln_fuzz_tests PRIVATE ${PROJECT_SOURCE_DIR}/src ${LN_SERVICES_GENERATED_DIR})
add_dependencies(ln_fuzz_tests ln_services_test_messages)
target_compile_definitions(ln_fuzz_tests PRIVATE LN_FUZZ_SOURCE_ROOT="${PROJECT_SOURCE_DIR}")
ln_target_warnings(ln_fuzz_tests)
gtest_discover_tests(ln_fuzz_tests PROPERTIES TIMEOUT 300 LABELS fuzz)
