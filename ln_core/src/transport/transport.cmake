# Shared-memory topic transport (data path of local publish/subscribe).
# include() this file from ln_core/CMakeLists.txt; it needs nothing but the C++
# standard library, Linux and (for the tests) GoogleTest.
#
# Targets:
#   ln_transport      static, position-independent library
#   shm_ring_test     GoogleTest unit and cross-process tests (if BUILD_TESTING)
#   ln29_shm_test     tests of the named LN 2.9-format segments (ln29_shm.hpp)
#   shm_ring_bench    micro-benchmark, one JSON line per result
# Consumers include headers as "transport/shm_ring.hpp".

set(LN_TRANSPORT_SOURCE_DIR ${CMAKE_CURRENT_LIST_DIR})
get_filename_component(LN_TRANSPORT_INCLUDE_DIR ${CMAKE_CURRENT_LIST_DIR} DIRECTORY)
find_package(Threads REQUIRED)

add_library(ln_transport STATIC
  ${LN_TRANSPORT_SOURCE_DIR}/shm_segment.cpp
  ${LN_TRANSPORT_SOURCE_DIR}/shm_ring.cpp
  ${LN_TRANSPORT_SOURCE_DIR}/ln29_shm.cpp)
set_target_properties(ln_transport PROPERTIES POSITION_INDEPENDENT_CODE ON)
target_compile_features(ln_transport PUBLIC cxx_std_17)
target_include_directories(ln_transport PUBLIC $<BUILD_INTERFACE:${LN_TRANSPORT_INCLUDE_DIR}>)
target_link_libraries(ln_transport PUBLIC Threads::Threads)
ln_target_warnings(ln_transport)

add_executable(shm_ring_bench ${LN_TRANSPORT_SOURCE_DIR}/shm_ring_bench.cpp)
target_link_libraries(shm_ring_bench PRIVATE ln_transport)
ln_target_warnings(shm_ring_bench)

if(BUILD_TESTING)
  enable_testing()  # idempotent; makes the include order irrelevant
  find_package(GTest REQUIRED)
  include(GoogleTest)
  add_executable(shm_ring_test ${LN_TRANSPORT_SOURCE_DIR}/shm_ring_test.cpp)
  target_link_libraries(shm_ring_test PRIVATE ln_transport GTest::gtest GTest::gtest_main)
  ln_target_warnings(shm_ring_test)
  gtest_discover_tests(shm_ring_test PROPERTIES TIMEOUT 60)
  add_executable(ln29_shm_test ${LN_TRANSPORT_SOURCE_DIR}/ln29_shm_test.cpp)
  target_link_libraries(ln29_shm_test PRIVATE ln_transport GTest::gtest GTest::gtest_main)
  ln_target_warnings(ln29_shm_test)
  gtest_discover_tests(ln29_shm_test PROPERTIES TIMEOUT 60)
endif()
