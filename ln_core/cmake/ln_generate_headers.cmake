# generate_ln_message_headers(): runs ln_generate at build time to write the
# C/C++ header for LN message definitions (ln_spec.md §3.4), with the
# arguments and behaviour of the function of the same name in LN 2.9's
# liblinks_and_nodes CMake package, so LN 2.9 CMakeLists work unmodified:
#
#   generate_ln_message_headers(<target>
#     OUTPUT <file>                 header to write; relative = below CMAKE_CURRENT_BINARY_DIR
#     MESSAGES <md name>...         definitions to generate, e.g. elevator/sensors/floor_count
#     [DIRECTORIES <dir>...]        definition directories, searched first (relative = below
#                                   CMAKE_CURRENT_SOURCE_DIR; "a:b" entries are split)
#     [WRAPPING_NS <ns>...]         --wrapping-ns for each
#     [MAP_SERVICE_BASE <X=Y>...]   --map-service-base for each
#     [PREFIX_NS_DEFINE <define>]   --prefix-ns-define
#     [OUTPUT_FORMAT <c++|jna|java>]  --output-format
#     [INSTALL_DIR <dir>]           install those DIRECTORIES that live inside the source tree
#     [GENERATOR <exe>]             use this ln_generate instead of the package's
#     [DIRECTORY <dir>]             deprecated single-directory form of DIRECTORIES
#     [ALLOW_ARRAY_OF_ONE])         accepted and ignored, as in LN 2.9
#
# As in LN 2.9 the definition directories passed to ln_generate are DIRECTORIES
# followed by LN_MESSAGE_DEFINITION_DIRS (the CMake variable, else the
# environment variable of that name); ln_generate itself still appends its
# built-in directories, ~/ln_message_definitions and md.conf expansions. The
# generator always gets -f (as in LN): the build system, not ln_generate's
# "is up to date" check, decides when to run it.
#
# What <target> becomes:
# - <target> does not exist yet (the LN 2.9 usage): it is created as a custom
#   target that generates the header, plus an INTERFACE library <target>_lib
#   that carries the header's directory as include path and depends on the
#   generation. Link <target>_lib to use the header.
# - <target> already exists (ln_core extension): it gets the header's
#   directory on its include path (PRIVATE for executables, INTERFACE for
#   interface libraries, PUBLIC otherwise; build tree only) and a dependency
#   on the generation. May be called several times for the same target.
#
# Incremental builds: ln_generate writes a depfile (--depfile) naming every
# definition file it read -- the requested ones, all they define, the md.conf
# files of the search path -- and the build tool reruns it when one of those
# changes (add_custom_command DEPFILE). Nothing is scanned at configure time.
# Where that is not possible (a generator without --depfile such as LN 2.9's,
# or CMake < 3.20 with a generator other than Ninja), every file below the
# search directories is a dependency instead.

# The depfile names absolute paths; the function keeps this setting
# (include() scopes it) so the caller's policies need not know about DEPFILE.
if(POLICY CMP0116)
  cmake_policy(SET CMP0116 NEW)
endif()

# Splits "a:b" entries (not on Windows), makes entries absolute relative to
# CMAKE_CURRENT_SOURCE_DIR, drops empty ones and duplicates (first one wins,
# keeping the search order).
function(_ln_normalize_md_dirs out_var)
  set(result "")
  foreach(entry IN LISTS ARGN)
    if(entry STREQUAL "")
      continue()
    endif()
    if(NOT WIN32)
      string(REPLACE ":" ";" parts "${entry}")
    else()
      set(parts "${entry}")
    endif()
    foreach(dir IN LISTS parts)
      if(dir STREQUAL "")
        continue()
      endif()
      get_filename_component(dir "${dir}" ABSOLUTE BASE_DIR "${CMAKE_CURRENT_SOURCE_DIR}")
      list(APPEND result "${dir}")
    endforeach()
  endforeach()
  list(REMOVE_DUPLICATES result)
  set(${out_var} "${result}" PARENT_SCOPE)
endfunction()

# Whether `generator` writes depfiles: ln_core's does (a target of this build,
# or a program whose --help names --depfile); LN 2.9's Python one does not.
function(_ln_generator_writes_depfile out_var generator)
  if(TARGET ${generator})
    set(${out_var} ON PARENT_SCOPE)
    return()
  endif()
  string(MAKE_C_IDENTIFIER "LN_GENERATE_DEPFILE_${generator}" cache_name)
  if(NOT DEFINED ${cache_name})
    execute_process(COMMAND "${generator}" --help OUTPUT_VARIABLE help ERROR_QUIET RESULT_VARIABLE rc)
    if(rc EQUAL 0 AND help MATCHES "--depfile")
      set(${cache_name} ON CACHE INTERNAL "")
    else()
      set(${cache_name} OFF CACHE INTERNAL "")
    endif()
  endif()
  set(${out_var} ${${cache_name}} PARENT_SCOPE)
endfunction()

function(generate_ln_message_headers _ln_target)
  set(options ALLOW_ARRAY_OF_ONE)
  set(one_value OUTPUT DIRECTORY INSTALL_DIR OUTPUT_FORMAT PREFIX_NS_DEFINE GENERATOR)
  set(multi_value MESSAGES DIRECTORIES MAP_SERVICE_BASE WRAPPING_NS)
  cmake_parse_arguments(ARG "${options}" "${one_value}" "${multi_value}" ${ARGN})
  set(fn generate_ln_message_headers)

  # --- argument checks -------------------------------------------------------
  if(_ln_target STREQUAL "" OR _ln_target IN_LIST options OR _ln_target IN_LIST one_value
     OR _ln_target IN_LIST multi_value)
    message(FATAL_ERROR "${fn}: the first argument must be the target name, e.g. "
      "${fn}(my_messages OUTPUT ln_messages.h MESSAGES my/topic)")
  endif()
  if(ARG_UNPARSED_ARGUMENTS)
    message(FATAL_ERROR "${fn}(${_ln_target}): unexpected argument(s): ${ARG_UNPARSED_ARGUMENTS}\n"
      "Known keywords: ${one_value};${multi_value};${options}")
  endif()
  if(NOT ARG_OUTPUT)
    message(FATAL_ERROR "${fn}(${_ln_target}): OUTPUT <header file> is required")
  endif()
  if(NOT ARG_MESSAGES)
    message(FATAL_ERROR "${fn}(${_ln_target}): MESSAGES <message definition names...> "
      "is required and must name at least one definition")
  endif()
  if(ARG_OUTPUT_FORMAT AND NOT ARG_OUTPUT_FORMAT MATCHES "^(c\\+\\+|jna|java)$")
    message(FATAL_ERROR "${fn}(${_ln_target}): OUTPUT_FORMAT must be c++, jna or java, "
      "not \"${ARG_OUTPUT_FORMAT}\"")
  endif()
  foreach(mapping IN LISTS ARG_MAP_SERVICE_BASE)
    if(NOT mapping MATCHES "^[^=]+=[^=]+$")
      message(FATAL_ERROR "${fn}(${_ln_target}): MAP_SERVICE_BASE entries have the form "
        "<md name>=<base name>, not \"${mapping}\"")
    endif()
  endforeach()
  if(TARGET ${_ln_target})
    get_target_property(aliased ${_ln_target} ALIASED_TARGET)
    if(aliased)
      set(_ln_target "${aliased}")
    endif()
    get_target_property(imported ${_ln_target} IMPORTED)
    get_target_property(type ${_ln_target} TYPE)
    if(imported OR type STREQUAL "UTILITY")
      message(FATAL_ERROR "${fn}(${_ln_target}): a custom or imported target of that name "
        "exists already; name a new target (LN 2.9 usage) or a library/executable of "
        "this project")
    endif()
  endif()

  # --- directories -----------------------------------------------------------
  if(ARG_DIRECTORY)
    message(DEPRECATION "${fn}: DIRECTORY is deprecated, use DIRECTORIES")
    list(APPEND ARG_DIRECTORIES "${ARG_DIRECTORY}")
  endif()
  _ln_normalize_md_dirs(given_dirs ${ARG_DIRECTORIES})
  foreach(dir IN LISTS given_dirs)
    if(NOT IS_DIRECTORY "${dir}")
      message(WARNING "${fn}(${_ln_target}): DIRECTORIES entry ${dir} is not a directory")
    endif()
  endforeach()
  if(DEFINED LN_MESSAGE_DEFINITION_DIRS)
    set(env_dirs ${LN_MESSAGE_DEFINITION_DIRS})
  elseif(DEFINED ENV{LN_MESSAGE_DEFINITION_DIRS})
    file(TO_CMAKE_PATH "$ENV{LN_MESSAGE_DEFINITION_DIRS}" env_dirs)
  else()
    set(env_dirs "")
  endif()
  _ln_normalize_md_dirs(md_dirs ${given_dirs} ${env_dirs})

  # --- output ----------------------------------------------------------------
  get_filename_component(output "${ARG_OUTPUT}" ABSOLUTE BASE_DIR "${CMAKE_CURRENT_BINARY_DIR}")
  get_filename_component(output_dir "${output}" DIRECTORY)

  # --- generator -------------------------------------------------------------
  set(generator_depends "")
  if(ARG_GENERATOR)
    set(generator "${ARG_GENERATOR}")
  elseif(liblinks_and_nodes_LN_GENERATE_EXECUTABLE)
    set(generator "${liblinks_and_nodes_LN_GENERATE_EXECUTABLE}")
  elseif(LN_GENERATE_EXECUTABLE)
    set(generator "${LN_GENERATE_EXECUTABLE}")
  elseif(TARGET ln_generate)
    # Inside the ln_core build tree.
    set(generator ln_generate)
  else()
    find_program(LN_GENERATE_EXECUTABLE NAMES ln_generate)
    if(NOT LN_GENERATE_EXECUTABLE)
      message(FATAL_ERROR "${fn}: ln_generate was not found; put it on PATH, set "
        "LN_GENERATE_EXECUTABLE, or pass GENERATOR <executable>")
    endif()
    set(generator "${LN_GENERATE_EXECUTABLE}")
  endif()
  if(TARGET ${generator})
    # An executable target: COMMAND and DEPENDS resolve it to its file.
    set(generator_depends ${generator})
  elseif(IS_ABSOLUTE "${generator}" AND EXISTS "${generator}")
    set(generator_depends "${generator}")
  endif()

  set(command "")
  if(liblinks_and_nodes_LN_GENERATE_PYTHONPATH)
    # LN 2.9 knob for Python generators; pointless for ln_core's native tool
    # but honoured so a GENERATOR pointing at LN's Python ln_generate works.
    set(pythonpath ${liblinks_and_nodes_LN_GENERATE_PYTHONPATH})
    if(NOT "$ENV{PYTHONPATH}" STREQUAL "")
      list(APPEND pythonpath "$ENV{PYTHONPATH}")
    endif()
    if(WIN32)
      string(REPLACE ";" "\\;" pythonpath "${pythonpath}")
    else()
      string(REPLACE ";" ":" pythonpath "${pythonpath}")
    endif()
    list(APPEND command "${CMAKE_COMMAND}" -E env "PYTHONPATH=${pythonpath}")
  endif()
  list(APPEND command "${generator}" -f -o "${output}")
  if(ARG_OUTPUT_FORMAT)
    list(APPEND command --output-format "${ARG_OUTPUT_FORMAT}")
  endif()
  if(ARG_PREFIX_NS_DEFINE)
    list(APPEND command --prefix-ns-define "${ARG_PREFIX_NS_DEFINE}")
  endif()
  foreach(ns IN LISTS ARG_WRAPPING_NS)
    list(APPEND command --wrapping-ns "${ns}")
  endforeach()
  foreach(mapping IN LISTS ARG_MAP_SERVICE_BASE)
    list(APPEND command --map-service-base "${mapping}")
  endforeach()
  foreach(dir IN LISTS md_dirs)
    list(APPEND command --md-dir "${dir}")
  endforeach()

  # --- dependencies: the depfile ln_generate writes ----------------------------
  _ln_generator_writes_depfile(writes_depfile "${generator}")
  if(writes_depfile AND (CMAKE_GENERATOR MATCHES "Ninja" OR NOT CMAKE_VERSION VERSION_LESS 3.21
     OR (CMAKE_GENERATOR MATCHES "Makefiles" AND NOT CMAKE_VERSION VERSION_LESS 3.20)))
    list(APPEND command --depfile "${output}.d")
    set(depends DEPFILE "${output}.d")
  else()
    set(depends DEPENDS)
    foreach(dir IN LISTS md_dirs)
      file(GLOB_RECURSE found LIST_DIRECTORIES false CONFIGURE_DEPENDS "${dir}/*")
      list(APPEND depends ${found})
    endforeach()
  endif()
  list(APPEND command ${ARG_MESSAGES})

  file(RELATIVE_PATH output_shown "${CMAKE_BINARY_DIR}" "${output}")
  add_custom_command(
    OUTPUT "${output}"
    COMMAND "${CMAKE_COMMAND}" -E make_directory "${output_dir}"
    COMMAND ${command}
    DEPENDS ${generator_depends}
    ${depends}
    COMMENT "Generating LN message header ${output_shown}"
    VERBATIM)
  set_property(SOURCE "${output}" PROPERTY GENERATED ON)

  # --- targets ---------------------------------------------------------------
  if(NOT TARGET ${_ln_target})
    add_custom_target(${_ln_target} DEPENDS "${output}")
    add_library(${_ln_target}_lib INTERFACE)
    add_dependencies(${_ln_target}_lib ${_ln_target})
    target_include_directories(${_ln_target}_lib INTERFACE "$<BUILD_INTERFACE:${output_dir}>")
  else()
    string(MD5 output_hash "${output}")
    string(SUBSTRING "${output_hash}" 0 8 output_hash)
    set(generation_target "${_ln_target}_ln_messages_${output_hash}")
    add_custom_target(${generation_target} DEPENDS "${output}")
    add_dependencies(${_ln_target} ${generation_target})
    get_target_property(type ${_ln_target} TYPE)
    if(type STREQUAL "EXECUTABLE")
      set(scope PRIVATE)
    elseif(type STREQUAL "INTERFACE_LIBRARY")
      set(scope INTERFACE)
    else()
      set(scope PUBLIC)
    endif()
    target_include_directories(${_ln_target} ${scope} "$<BUILD_INTERFACE:${output_dir}>")
  endif()

  # --- INSTALL_DIR: ship the project's own definition directories -------------
  if(ARG_INSTALL_DIR)
    foreach(dir IN LISTS md_dirs)
      file(RELATIVE_PATH relative "${CMAKE_SOURCE_DIR}" "${dir}")
      if(relative MATCHES "^\\.\\." OR IS_ABSOLUTE "${relative}" OR NOT IS_DIRECTORY "${dir}")
        continue()
      endif()
      install(DIRECTORY "${dir}/" DESTINATION "${ARG_INSTALL_DIR}"
        FILES_MATCHING PATTERN "*"
        PATTERN "*.txt" EXCLUDE
        PATTERN ".git*" EXCLUDE
        PATTERN ".svn*" EXCLUDE
        PATTERN "*.swp" EXCLUDE
        PATTERN "*~" EXCLUDE)
    endforeach()
  endif()
endfunction()
