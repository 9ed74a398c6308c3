# Cross-process topic tests: publishers and subscribers written as for LN 2.9
# (C and C++, headers from generate_ln_message_headers), started as separate
# processes by the gtest driver ln_topic_tests, plus the benchmark programs
# (see run_bench.sh). Included by src/client/client.cmake.

set(LN_TOPICS_TEST_DIR ${CMAKE_CURRENT_LIST_DIR})
if(NOT COMMAND generate_ln_message_headers)
  include(${LN_CLIENT_ROOT_DIR}/cmake/ln_generate_headers.cmake)
endif()

# LN 2.9 usage: creates ln_topics_test_messages and ln_topics_test_messages_lib.
generate_ln_message_headers(ln_topics_test_messages
  OUTPUT ln_topics_test/ln_messages.h
  MESSAGES test/p64
  DIRECTORIES ${LN_TOPICS_TEST_DIR}/msgdefs)

foreach(program ln_test_publisher.c ln_test_subscriber.cpp ln_bench_pingpong.cpp ln_bench_rate.cpp)
  get_filename_component(name ${program} NAME_WE)
  add_executable(${name} ${LN_TOPICS_TEST_DIR}/${program})
  target_link_libraries(${name} PRIVATE ln ln_topics_test_messages_lib)
  ln_target_warnings(${name})
endforeach()

add_executable(ln_topic_tests ${LN_TOPICS_TEST_DIR}/topics_process_test.cpp
                              ${LN_TOPICS_TEST_DIR}/loggers_process_test.cpp)
target_link_libraries(ln_topic_tests PRIVATE ln ln_manager_core GTest::gtest GTest::gtest_main)
target_include_directories(ln_topic_tests PRIVATE ${LN_CLIENT_SRC_DIR})
target_compile_definitions(ln_topic_tests PRIVATE
  LN_TEST_MD_DIR="${LN_TOPICS_TEST_DIR}/msgdefs"
  LN_TEST_PUBLISHER="$<TARGET_FILE:ln_test_publisher>"
  LN_TEST_SUBSCRIBER="$<TARGET_FILE:ln_test_subscriber>"
  LN_BENCH_PINGPONG="$<TARGET_FILE:ln_bench_pingpong>"
  LN_BENCH_RATE="$<TARGET_FILE:ln_bench_rate>")
add_dependencies(ln_topic_tests ln_test_publisher ln_test_subscriber ln_bench_pingpong ln_bench_rate)
ln_target_warnings(ln_topic_tests)
gtest_discover_tests(ln_topic_tests PROPERTIES TIMEOUT 120)
