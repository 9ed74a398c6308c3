# What every package of this workspace (ln_core, msg_mapping, ln_bag) builds the same way:
# the language level and build type, warnings and sanitizers, nanobind modules and their
# pure-Python package beside them. ln_core includes this file; the others get it from
# find_package(ln), which installs it with the package.
include_guard(GLOBAL)

# ln_project_defaults(PREFIX): C++17, RelWithDebInfo unless told otherwise, and the options
# <PREFIX>_WERROR (warnings are errors, default ON) and <PREFIX>_SANITIZE (ASan and UBSan for
# everything this directory builds, default OFF). A macro: it sets the caller's scope.
macro(ln_project_defaults prefix)
  option(${prefix}_WERROR "Treat compiler warnings as errors" ON)
  option(${prefix}_SANITIZE "Build with AddressSanitizer and UndefinedBehaviorSanitizer" OFF)
  set(LN_PROJECT_WERROR ${${prefix}_WERROR})
  set(CMAKE_CXX_STANDARD 17)
  set(CMAKE_CXX_STANDARD_REQUIRED ON)
  set(CMAKE_CXX_EXTENSIONS OFF)
  set(CMAKE_POSITION_INDEPENDENT_CODE ON)
  if(NOT CMAKE_BUILD_TYPE AND NOT CMAKE_CONFIGURATION_TYPES)
    set(CMAKE_BUILD_TYPE RelWithDebInfo)
  endif()
  if(${prefix}_SANITIZE)
    add_compile_options(-fsanitize=address,undefined -fno-sanitize-recover=undefined -fno-omit-frame-pointer)
    add_link_options(-fsanitize=address,undefined)
  endif()
endmacro()

# ln_target_warnings(TARGET): the project's warnings, errors when <PREFIX>_WERROR is on.
function(ln_target_warnings target)
  target_compile_options(${target} PRIVATE
    -Wall -Wextra -Wpedantic -Wshadow -Wcast-align -Wformat=2
    $<$<COMPILE_LANGUAGE:CXX>:-Wnon-virtual-dtor -Woverloaded-virtual>
    $<$<BOOL:${LN_PROJECT_WERROR}>:-Werror>)
endfunction()

# ln_find_nanobind(): the Python interpreter (LN_PYTHON_EXECUTABLE or Python_EXECUTABLE if
# given, else FindPython's choice: the active virtual environment's) and the nanobind
# installed for it, found through `python -m nanobind --cmake_dir`.
macro(ln_find_nanobind)
  if(LN_PYTHON_EXECUTABLE AND NOT DEFINED Python_EXECUTABLE)
    set(Python_EXECUTABLE "${LN_PYTHON_EXECUTABLE}")
  endif()
  find_package(Python 3.8 REQUIRED COMPONENTS Interpreter Development.Module)
  execute_process(COMMAND "${Python_EXECUTABLE}" -m nanobind --cmake_dir
                  OUTPUT_VARIABLE _ln_nanobind_dir OUTPUT_STRIP_TRAILING_WHITESPACE
                  RESULT_VARIABLE _ln_nanobind_result)
  if(NOT _ln_nanobind_result EQUAL 0)
    message(FATAL_ERROR "nanobind is not installed for ${Python_EXECUTABLE} (pip install nanobind)")
  endif()
  list(APPEND CMAKE_PREFIX_PATH "${_ln_nanobind_dir}")
  find_package(nanobind CONFIG REQUIRED)
  # Where a package's pure-Python part goes under the install prefix.
  set(LN_PYTHON_SITE_PACKAGES "lib/python${Python_VERSION_MAJOR}.${Python_VERSION_MINOR}/site-packages")
endmacro()

# ln_nanobind_module(TARGET SOURCES...): nanobind_add_module(... NB_STATIC ...) with the
# project's warnings; nanobind's own headers count as system headers (not ours to keep clean).
function(ln_nanobind_module target)
  nanobind_add_module(${target} NB_STATIC ${ARGN})
  ln_target_warnings(${target})
  foreach(lib nanobind-static nanobind)
    if(TARGET ${lib})
      get_target_property(includes ${lib} INTERFACE_INCLUDE_DIRECTORIES)
      set_target_properties(${lib} PROPERTIES INTERFACE_SYSTEM_INCLUDE_DIRECTORIES "${includes}")
    endif()
  endforeach()
endfunction()

# ln_python_sources(TARGET SOURCE_DIR BUILD_DIR): copies the pure-Python package in SOURCE_DIR
# (*.py, *.pyi, py.typed, sub-packages too) to BUILD_DIR when it changes, so that tests import
# the package from the build tree next to its native module; the custom target TARGET does it.
# Sets LN_PYTHON_SOURCES (paths relative to SOURCE_DIR) in the caller's scope.
function(ln_python_sources target source_dir build_dir)
  file(GLOB_RECURSE sources CONFIGURE_DEPENDS RELATIVE ${source_dir}
       ${source_dir}/*.py ${source_dir}/*.pyi ${source_dir}/py.typed)
  set(copies "")
  foreach(name ${sources})
    add_custom_command(OUTPUT ${build_dir}/${name}
                       COMMAND ${CMAKE_COMMAND} -E copy_if_different ${source_dir}/${name} ${build_dir}/${name}
                       DEPENDS ${source_dir}/${name} VERBATIM)
    list(APPEND copies ${build_dir}/${name})
  endforeach()
  add_custom_target(${target} ALL DEPENDS ${copies})
  set(LN_PYTHON_SOURCES ${sources} PARENT_SCOPE)
endfunction()

# ln_install_python_sources(SOURCE_DIR DESTINATION [install() options]): installs the files
# ln_python_sources() found, each into DESTINATION/<its sub-directory>.
function(ln_install_python_sources source_dir destination)
  foreach(name ${LN_PYTHON_SOURCES})
    get_filename_component(subdir ${name} DIRECTORY)
    install(FILES ${source_dir}/${name} DESTINATION ${destination}/${subdir} ${ARGN})
  endforeach()
endfunction()

# ln_add_pytest_files(PREFIX DIRECTORY TIMEOUT [ENVIRONMENT entries...]): one ctest entry
# PREFIX_<name> per DIRECTORY/test_<name>.py, run by pytest with a JUnit report in the build
# tree. "@NAME@" in an environment entry stands for the file's name (without .py).
function(ln_add_pytest_files prefix directory timeout)
  file(GLOB files CONFIGURE_DEPENDS ${directory}/test_*.py)
  foreach(test_file IN LISTS files)
    get_filename_component(name ${test_file} NAME_WE)
    add_test(NAME ${prefix}_${name}
             COMMAND "${Python_EXECUTABLE}" -m pytest "${test_file}" -q -p no:cacheprovider
                     --junitxml=${CMAKE_CURRENT_BINARY_DIR}/${name}-junit.xml)
    string(REPLACE "@NAME@" "${name}" environment "${ARGN}")
    set_tests_properties(${prefix}_${name} PROPERTIES TIMEOUT ${timeout} ENVIRONMENT "${environment}")
  endforeach()
endfunction()
