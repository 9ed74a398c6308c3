# ln_add_test(): the one way a test of ln_core is registered with ctest, called
# next to the code it tests (each component's CMakeLists.txt, if BUILD_TESTING).
#
#   ln_add_test(<name> SOURCES <file>... [LIBRARIES <target>...] [TIMEOUT <s>]
#               [PROGRAMS <MACRO>=<target>...])
#     A GoogleTest program <name> (gtest_main and ln_testing linked, our
#     warnings); every test case becomes its own ctest entry. PROGRAMS: the
#     test starts these executables, named by the string macro MACRO (their
#     path) and built before it. Give it further definitions or include
#     directories with target_*() afterwards.
#   ln_add_test(<name> COMMAND <program> <arg>... [TIMEOUT <s>] [LABELS <label>...]
#               [ENVIRONMENT <VAR=value>...] [RUN_SERIAL])
#     One ctest entry that runs a program or script; exit code 77 means skipped
#     (a missing prerequisite; the scripts fail instead when CI is set).
# TIMEOUT defaults to 60 s.
function(ln_add_test name)
  cmake_parse_arguments(ARG "RUN_SERIAL" "TIMEOUT" "SOURCES;LIBRARIES;PROGRAMS;COMMAND;LABELS;ENVIRONMENT" ${ARGN})
  if(ARG_UNPARSED_ARGUMENTS OR (ARG_SOURCES AND ARG_COMMAND) OR NOT (ARG_SOURCES OR ARG_COMMAND))
    message(FATAL_ERROR "ln_add_test(${name}): give either SOURCES or COMMAND (see cmake/ln_add_test.cmake)")
  endif()
  if(NOT ARG_TIMEOUT)
    set(ARG_TIMEOUT 60)
  endif()
  if(ARG_SOURCES)
    add_executable(${name} ${ARG_SOURCES})
    target_link_libraries(${name} PRIVATE ${ARG_LIBRARIES} ln_testing GTest::gtest GTest::gtest_main)
    ln_target_warnings(${name})
    gtest_discover_tests(${name} PROPERTIES TIMEOUT ${ARG_TIMEOUT})
    foreach(program IN LISTS ARG_PROGRAMS)
      string(REGEX MATCH "^([A-Za-z_0-9]+)=(.+)$" matched "${program}")
      if(NOT matched)
        message(FATAL_ERROR "ln_add_test(${name}): PROGRAMS entry '${program}' is not MACRO=target")
      endif()
      target_compile_definitions(${name} PRIVATE "${CMAKE_MATCH_1}=\"$<TARGET_FILE:${CMAKE_MATCH_2}>\"")
      add_dependencies(${name} ${CMAKE_MATCH_2})
    endforeach()
    return()
  endif()
  add_test(NAME ${name} COMMAND ${ARG_COMMAND})
  set_tests_properties(${name} PROPERTIES TIMEOUT ${ARG_TIMEOUT} SKIP_RETURN_CODE 77)
  if(ARG_LABELS)
    set_tests_properties(${name} PROPERTIES LABELS "${ARG_LABELS}")
  endif()
  if(ARG_ENVIRONMENT)
    set_tests_properties(${name} PROPERTIES ENVIRONMENT "${ARG_ENVIRONMENT}")
  endif()
  if(ARG_RUN_SERIAL)
    set_tests_properties(${name} PROPERTIES RUN_SERIAL TRUE)
  endif()
endfunction()
