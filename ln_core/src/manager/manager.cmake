# The ln_manager: the manager logic as a static library (so tests can run it
# in-process), the ln_manager daemon, and their tests. Included from
# ln_core/CMakeLists.txt after ln_md, ln_protocol and ln_target_warnings exist.
find_package(Threads REQUIRED)

set(LN_MANAGER_SOURCE_DIR ${CMAKE_CURRENT_LIST_DIR})

add_library(ln_manager_core STATIC
  ${LN_MANAGER_SOURCE_DIR}/child_process.cpp
  ${LN_MANAGER_SOURCE_DIR}/config.cpp
  ${LN_MANAGER_SOURCE_DIR}/config_objects.cpp
  ${LN_MANAGER_SOURCE_DIR}/definitions.cpp
  ${LN_MANAGER_SOURCE_DIR}/dispatch.cpp
  ${LN_MANAGER_SOURCE_DIR}/events.cpp
  ${LN_MANAGER_SOURCE_DIR}/line_regex.cpp
  ${LN_MANAGER_SOURCE_DIR}/lnc_eval.cpp
  ${LN_MANAGER_SOURCE_DIR}/log_files.cpp
  ${LN_MANAGER_SOURCE_DIR}/loggers.cpp
  ${LN_MANAGER_SOURCE_DIR}/manager.cpp
  ${LN_MANAGER_SOURCE_DIR}/names.cpp
  ${LN_MANAGER_SOURCE_DIR}/process_control.cpp
  ${LN_MANAGER_SOURCE_DIR}/process_keeper.cpp
  ${LN_MANAGER_SOURCE_DIR}/process_launch.cpp
  ${LN_MANAGER_SOURCE_DIR}/process_methods.cpp
  ${LN_MANAGER_SOURCE_DIR}/process_output.cpp
  ${LN_MANAGER_SOURCE_DIR}/recorder.cpp
  ${LN_MANAGER_SOURCE_DIR}/registry.cpp
  ${LN_MANAGER_SOURCE_DIR}/sample_log.cpp
)
target_include_directories(ln_manager_core PUBLIC ${LN_MANAGER_SOURCE_DIR}/..)
target_link_libraries(ln_manager_core PUBLIC ln_md ln_protocol ln_transport Threads::Threads)
# libmatio writes the MATLAB files of ln_logger_manager_save(); without it
# (e.g. a pip build elsewhere) those formats answer with an error saying so.
find_package(PkgConfig)
if(PkgConfig_FOUND)
  pkg_check_modules(MATIO IMPORTED_TARGET matio)
endif()
if(MATIO_FOUND)
  target_link_libraries(ln_manager_core PRIVATE PkgConfig::MATIO)
  target_compile_definitions(ln_manager_core PRIVATE LN_WITH_MATIO)
else()
  message(STATUS "libmatio not found (Debian: libmatio-dev): manager_save will refuse the MATLAB formats")
endif()
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
    ${LN_MANAGER_SOURCE_DIR}/config_objects_test.cpp
    ${LN_MANAGER_SOURCE_DIR}/lnc_eval_test.cpp
    ${LN_MANAGER_SOURCE_DIR}/line_regex_test.cpp
    ${LN_MANAGER_SOURCE_DIR}/process_control_test.cpp
    ${LN_MANAGER_SOURCE_DIR}/manager_test.cpp
    ${LN_MANAGER_SOURCE_DIR}/introspection_test.cpp
    ${LN_MANAGER_SOURCE_DIR}/robustness_test.cpp
    ${LN_MANAGER_SOURCE_DIR}/binary_test.cpp
    ${LN_MANAGER_SOURCE_DIR}/events_test.cpp
    ${LN_MANAGER_SOURCE_DIR}/log_files_test.cpp
    ${LN_MANAGER_SOURCE_DIR}/loggers_test.cpp
    ${LN_MANAGER_SOURCE_DIR}/recorder_test.cpp
    ${LN_MANAGER_SOURCE_DIR}/sample_log_test.cpp
    ${LN_MANAGER_SOURCE_DIR}/service_loggers_test.cpp
  )
  target_link_libraries(manager_tests PRIVATE ln_manager_core GTest::gtest GTest::gtest_main)
  if(MATIO_FOUND)  # the MATLAB files are read back with libmatio
    target_link_libraries(manager_tests PRIVATE PkgConfig::MATIO)
    target_compile_definitions(manager_tests PRIVATE LN_WITH_MATIO)
  endif()
  # The binary test starts the real daemon.
  target_compile_definitions(manager_tests PRIVATE LN_MANAGER_BINARY="$<TARGET_FILE:ln_manager>")
  add_dependencies(manager_tests ln_manager)
  ln_target_warnings(manager_tests)
  gtest_discover_tests(manager_tests PROPERTIES TIMEOUT 60)
endif()
