# The ln_manager: the manager logic as a static library (so tests can run it
# in-process), the ln_manager daemon, and their tests. Included from
# ln_core/CMakeLists.txt after ln_md, ln_protocol and ln_target_warnings exist.
find_package(Threads REQUIRED)

set(LN_MANAGER_SOURCE_DIR ${CMAKE_CURRENT_LIST_DIR})

add_library(ln_manager_core STATIC
  ${LN_MANAGER_SOURCE_DIR}/config.cpp
  ${LN_MANAGER_SOURCE_DIR}/definitions.cpp
  ${LN_MANAGER_SOURCE_DIR}/dispatch.cpp
  ${LN_MANAGER_SOURCE_DIR}/limits.cpp
  ${LN_MANAGER_SOURCE_DIR}/manager.cpp
  ${LN_MANAGER_SOURCE_DIR}/names.cpp
  ${LN_MANAGER_SOURCE_DIR}/registry.cpp
)
target_include_directories(ln_manager_core PUBLIC ${LN_MANAGER_SOURCE_DIR}/..)
# ln_transport: the size of a topic's segment, which the shared-memory limits count.
target_link_libraries(ln_manager_core PUBLIC ln_md ln_protocol ln_transport Threads::Threads)
target_compile_definitions(ln_manager_core PRIVATE LN_MANAGER_VERSION="${PROJECT_VERSION}")
ln_target_warnings(ln_manager_core)

add_executable(ln_manager ${LN_MANAGER_SOURCE_DIR}/../../tools/ln_manager.cpp)
target_link_libraries(ln_manager PRIVATE ln_manager_core)
ln_target_warnings(ln_manager)
install(TARGETS ln_manager RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})

if(BUILD_TESTING)
  find_package(GTest REQUIRED)
  include(GoogleTest)
  add_executable(manager_tests
    ${LN_MANAGER_SOURCE_DIR}/names_test.cpp
    ${LN_MANAGER_SOURCE_DIR}/config_test.cpp
    ${LN_MANAGER_SOURCE_DIR}/manager_test.cpp
    ${LN_MANAGER_SOURCE_DIR}/introspection_test.cpp
    ${LN_MANAGER_SOURCE_DIR}/robustness_test.cpp
    ${LN_MANAGER_SOURCE_DIR}/limits_test.cpp
    ${LN_MANAGER_SOURCE_DIR}/binary_test.cpp
  )
  target_link_libraries(manager_tests PRIVATE ln_manager_core GTest::gtest GTest::gtest_main)
  # The binary test starts the real daemon.
  target_compile_definitions(manager_tests PRIVATE LN_MANAGER_BINARY="$<TARGET_FILE:ln_manager>")
  add_dependencies(manager_tests ln_manager)
  ln_target_warnings(manager_tests)
  gtest_discover_tests(manager_tests PROPERTIES TIMEOUT 60)
endif()
