# The Python package links_and_nodes on ln_core: the native module
# links_and_nodes._ln (nanobind, over libln's C API and the md model) plus the
# pure-Python package. include() this file from ln_core/CMakeLists.txt after
# the targets `ln` (client.cmake) and `ln_md` exist.
#
# nanobind is found through the Python interpreter LN_PYTHON_EXECUTABLE
# (default: the active venv's python, else the project venv
# ${LN_CORE_CACHE:-~/.cache/ln_core}/venv-ros, else python3 on PATH):
# `python -m nanobind --cmake_dir`.
#
# Results:
#   build tree: ${CMAKE_BINARY_DIR}/python/links_and_nodes (importable with
#               PYTHONPATH=${CMAKE_BINARY_DIR}/python)
#   install:    <prefix>/lib/python3.X/site-packages/links_and_nodes
#               (LN_PYTHON_INSTALL_DIR), the module finds libln.so through
#               its RUNPATH; under scikit-build-core (pip install) libln.so
#               goes into the package directory instead.
# Tests: ctest runs the pytest suite (ln_python_tests) if BUILD_TESTING.

set(LN_PYTHON_DIR ${CMAKE_CURRENT_LIST_DIR})

set(_ln_default_python python3)
if(DEFINED ENV{LN_CORE_CACHE})
  set(_ln_project_venv "$ENV{LN_CORE_CACHE}/venv-ros")
else()
  set(_ln_project_venv "$ENV{HOME}/.cache/ln_core/venv-ros")
endif()
if(DEFINED ENV{VIRTUAL_ENV} AND EXISTS "$ENV{VIRTUAL_ENV}/bin/python")
  set(_ln_default_python "$ENV{VIRTUAL_ENV}/bin/python")
elseif(EXISTS "${_ln_project_venv}/bin/python")
  set(_ln_default_python "${_ln_project_venv}/bin/python")
endif()
set(LN_PYTHON_EXECUTABLE "${_ln_default_python}" CACHE FILEPATH "Python interpreter the links_and_nodes module is built for")
if(NOT DEFINED Python_EXECUTABLE)
  set(Python_EXECUTABLE "${LN_PYTHON_EXECUTABLE}")
endif()
find_package(Python 3.8 REQUIRED COMPONENTS Interpreter Development.Module)
execute_process(
  COMMAND "${Python_EXECUTABLE}" -m nanobind --cmake_dir
  OUTPUT_VARIABLE _ln_nanobind_dir OUTPUT_STRIP_TRAILING_WHITESPACE
  RESULT_VARIABLE _ln_nanobind_result)
if(NOT _ln_nanobind_result EQUAL 0)
  message(FATAL_ERROR "links_and_nodes: nanobind not found for ${Python_EXECUTABLE} (pip install nanobind)")
endif()
list(APPEND CMAKE_PREFIX_PATH "${_ln_nanobind_dir}")
find_package(nanobind CONFIG REQUIRED)

set(LN_PYTHON_PACKAGE_BUILD_DIR ${CMAKE_BINARY_DIR}/python/links_and_nodes)
nanobind_add_module(ln_python NB_STATIC
  ${LN_PYTHON_DIR}/src/module.cpp
  ${LN_PYTHON_DIR}/src/model.cpp
  ${LN_PYTHON_DIR}/src/introspection.cpp
  ${LN_PYTHON_DIR}/src/loggers.cpp
  ${LN_PYTHON_DIR}/src/parameters.cpp)
target_link_libraries(ln_python PRIVATE ln ln_md)
target_compile_options(ln_python PRIVATE -Wall -Wextra)
target_include_directories(ln_python PRIVATE ${LN_PYTHON_DIR}/src
  ${CMAKE_CURRENT_LIST_DIR}/../src)  # md/parser.hpp (the model's import scanner)
set_target_properties(ln_python PROPERTIES
  OUTPUT_NAME _ln
  LIBRARY_OUTPUT_DIRECTORY ${LN_PYTHON_PACKAGE_BUILD_DIR})

# The pure-Python part (with its sub-packages, e.g. cli/) is copied next to
# the module in the build tree.
# (_ln.pyi: the native module's stub; py.typed: the package ships its types.)
file(GLOB_RECURSE LN_PYTHON_SOURCES CONFIGURE_DEPENDS RELATIVE ${LN_PYTHON_DIR}/links_and_nodes
  ${LN_PYTHON_DIR}/links_and_nodes/*.py ${LN_PYTHON_DIR}/links_and_nodes/*.pyi
  ${LN_PYTHON_DIR}/links_and_nodes/py.typed)
set(_ln_python_copies)
foreach(_name ${LN_PYTHON_SOURCES})
  add_custom_command(OUTPUT ${LN_PYTHON_PACKAGE_BUILD_DIR}/${_name}
    COMMAND ${CMAKE_COMMAND} -E copy_if_different ${LN_PYTHON_DIR}/links_and_nodes/${_name}
            ${LN_PYTHON_PACKAGE_BUILD_DIR}/${_name}
    DEPENDS ${LN_PYTHON_DIR}/links_and_nodes/${_name} VERBATIM)
  list(APPEND _ln_python_copies ${LN_PYTHON_PACKAGE_BUILD_DIR}/${_name})
endforeach()
add_custom_target(ln_python_package ALL DEPENDS ${_ln_python_copies})
add_dependencies(ln_python ln_python_package)

# install(FILES) of the pure-Python part into DESTINATION/<its sub-directory>.
function(ln_python_install_sources destination)
  foreach(_name ${LN_PYTHON_SOURCES})
    get_filename_component(_subdir ${_name} DIRECTORY)
    install(FILES ${LN_PYTHON_DIR}/links_and_nodes/${_name} DESTINATION ${destination}/${_subdir} ${ARGN})
  endforeach()
endfunction()

if(SKBUILD)
  # pip install: a self-contained wheel with libln.so beside the module.
  set_target_properties(ln_python PROPERTIES INSTALL_RPATH "$ORIGIN")
  # One real file libln.so.1 (wheels cannot hold symlinks).
  set_target_properties(ln PROPERTIES INSTALL_RPATH "$ORIGIN" VERSION 1 SOVERSION 1)
  install(TARGETS ln_python LIBRARY DESTINATION links_and_nodes COMPONENT python)
  install(TARGETS ln LIBRARY DESTINATION links_and_nodes NAMELINK_SKIP COMPONENT python)
  ln_python_install_sources(links_and_nodes COMPONENT python)
else()
  set(LN_PYTHON_INSTALL_DIR
    "${CMAKE_INSTALL_LIBDIR}/python${Python_VERSION_MAJOR}.${Python_VERSION_MINOR}/site-packages"
    CACHE STRING "Where links_and_nodes is installed (relative to the prefix)")
  file(RELATIVE_PATH _ln_rpath "/x/${LN_PYTHON_INSTALL_DIR}/links_and_nodes" "/x/${CMAKE_INSTALL_LIBDIR}")
  set_target_properties(ln_python PROPERTIES INSTALL_RPATH "$ORIGIN/${_ln_rpath}")
  install(TARGETS ln_python LIBRARY DESTINATION ${LN_PYTHON_INSTALL_DIR}/links_and_nodes)
  ln_python_install_sources(${LN_PYTHON_INSTALL_DIR}/links_and_nodes)
  # The `ln` command (links_and_nodes.cli) in <prefix>/bin, which env.sh puts
  # on PATH; in the build tree as python/ln (LN_CORE_LN of the tests).
  file(RELATIVE_PATH LN_CLI_PACKAGE_PARENT "/x/${CMAKE_INSTALL_BINDIR}" "/x/${LN_PYTHON_INSTALL_DIR}")
  configure_file(${LN_PYTHON_DIR}/ln.in ${CMAKE_BINARY_DIR}/python/ln.install @ONLY)
  install(PROGRAMS ${CMAKE_BINARY_DIR}/python/ln.install DESTINATION ${CMAKE_INSTALL_BINDIR} RENAME ln)
endif()
set(LN_CLI_PACKAGE_PARENT ".")
configure_file(${LN_PYTHON_DIR}/ln.in ${CMAKE_BINARY_DIR}/ln-launcher/ln @ONLY)
file(COPY ${CMAKE_BINARY_DIR}/ln-launcher/ln DESTINATION ${CMAKE_BINARY_DIR}/python
  FILE_PERMISSIONS OWNER_READ OWNER_WRITE OWNER_EXECUTE GROUP_READ GROUP_EXECUTE WORLD_READ WORLD_EXECUTE)

# Not in a sanitizer build: an instrumented extension module would need the
# sanitizer runtime preloaded into the interpreter. The sanitizer build still
# covers everything the module calls (libln's C API tests).
if(BUILD_TESTING AND TARGET ln_manager AND NOT LN_SANITIZE)
  add_test(NAME ln_python_tests
    COMMAND ${Python_EXECUTABLE} -m pytest -q -p no:cacheprovider ${LN_PYTHON_DIR}/tests)
  set_tests_properties(ln_python_tests PROPERTIES
    TIMEOUT 600
    ENVIRONMENT "PYTHONPATH=${CMAKE_BINARY_DIR}/python;LN_CORE_MANAGER=$<TARGET_FILE:ln_manager>;LN_CORE_GENERATE=$<TARGET_FILE:ln_generate>;LN_CORE_INCLUDE_DIR=${CMAKE_CURRENT_LIST_DIR}/../include;LN_CORE_LIB=$<TARGET_FILE:ln>;LN_CORE_LN=${CMAKE_BINARY_DIR}/python/ln")
endif()
