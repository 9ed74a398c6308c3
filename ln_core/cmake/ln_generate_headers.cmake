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
# Incremental builds: the header is an add_custom_command OUTPUT that DEPENDS
# on ln_generate and on the files of the requested definitions and of every
# definition they import (recursively), so it is regenerated only when one of
# those changes. The files are resolved at configure time by asking ln_md_info
# -- it links the same search-path and `define` resolution code as
# ln_generate, so the dependency list cannot disagree with what the generator
# reads (md.conf expansion, imports relative to the importing file, built-in
# dirs). Those files are also CMAKE_CONFIGURE_DEPENDS, so editing a
# definition re-runs CMake and picks up added or removed imports. Without a
# usable ln_md_info (inside the ln_core build tree, where it is not built yet
# at configure time, or CMake < 3.19 which lacks string(JSON)) every file below
# the search directories is a dependency instead (GLOB_RECURSE
# CONFIGURE_DEPENDS): coarser, but never misses a change in those directories.
# Setting LN_GENERATE_DEPENDENCY_SCAN to GLOB selects that fallback always.

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

# The ln_md_info to resolve definition files with, or "" if none is usable.
function(_ln_find_md_info out_var)
  set(${out_var} "" PARENT_SCOPE)
  if(CMAKE_VERSION VERSION_LESS 3.19 OR LN_GENERATE_DEPENDENCY_SCAN STREQUAL "GLOB")
    return()
  endif()
  if(LN_MD_INFO_EXECUTABLE AND EXISTS "${LN_MD_INFO_EXECUTABLE}"
     AND NOT IS_DIRECTORY "${LN_MD_INFO_EXECUTABLE}")
    set(${out_var} "${LN_MD_INFO_EXECUTABLE}" PARENT_SCOPE)
  endif()
endfunction()

# Sets out_var to the files of the definitions `names` and of everything they
# import, using ln_md_info with --md-dir for each of `dirs`.
function(_ln_md_files_via_md_info out_var md_info dirs names)
  set(dir_args "")
  foreach(dir IN LISTS dirs)
    list(APPEND dir_args --md-dir "${dir}")
  endforeach()
  set(files "")
  set(seen "")
  set(pending ${names})
  while(pending)
    list(APPEND seen ${pending})
    execute_process(
      COMMAND "${md_info}" ${dir_args} ${pending}
      WORKING_DIRECTORY "${CMAKE_CURRENT_BINARY_DIR}"
      RESULT_VARIABLE rc
      OUTPUT_VARIABLE out
      ERROR_VARIABLE err)
    if(NOT rc EQUAL 0)
      string(STRIP "${err}" err)
      string(REPLACE ";" " " pending_text "${pending}")
      message(FATAL_ERROR
        "generate_ln_message_headers: cannot load the LN message definition(s) "
        "${pending_text}:\n  ${err}")
    endif()
    set(pending "")
    # One JSON object per line. Walk the lines by position rather than turning
    # the output into a list: JSON brackets would confuse CMake's list syntax.
    while(NOT out STREQUAL "")
      string(FIND "${out}" "\n" eol)
      if(eol EQUAL -1)
        set(line "${out}")
        set(out "")
      else()
        string(SUBSTRING "${out}" 0 ${eol} line)
        math(EXPR rest_begin "${eol} + 1")
        string(SUBSTRING "${out}" ${rest_begin} -1 out)
      endif()
      string(STRIP "${line}" line)
      if(line STREQUAL "")
        continue()
      endif()
      string(JSON path GET "${line}" path)
      get_filename_component(path "${path}" ABSOLUTE BASE_DIR "${CMAKE_CURRENT_BINARY_DIR}")
      list(APPEND files "${path}")
      string(JSON define_count LENGTH "${line}" defines)
      if(define_count GREATER 0)
        math(EXPR last "${define_count} - 1")
        foreach(i RANGE ${last})
          string(JSON imported GET "${line}" defines ${i} name)
          if(NOT imported IN_LIST seen AND NOT imported IN_LIST pending)
            list(APPEND pending "${imported}")
          endif()
        endforeach()
      endif()
    endwhile()
  endwhile()
  list(REMOVE_DUPLICATES files)
  set(${out_var} "${files}" PARENT_SCOPE)
endfunction()

# Fallback: every file below the search directories (and ln_generate's
# built-in directory when known).
function(_ln_md_files_via_glob out_var dirs)
  set(files "")
  foreach(dir IN LISTS dirs LN_BUILTIN_MESSAGE_DEFINITION_DIR)
    if(IS_DIRECTORY "${dir}")
      file(GLOB_RECURSE found LIST_DIRECTORIES false CONFIGURE_DEPENDS "${dir}/*")
      list(APPEND files ${found})
    endif()
  endforeach()
  list(REMOVE_DUPLICATES files)
  set(${out_var} "${files}" PARENT_SCOPE)
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
  list(APPEND command ${ARG_MESSAGES})

  # --- dependencies ----------------------------------------------------------
  _ln_find_md_info(md_info)
  if(md_info)
    _ln_md_files_via_md_info(md_files "${md_info}" "${md_dirs}" "${ARG_MESSAGES}")
    set_property(DIRECTORY APPEND PROPERTY CMAKE_CONFIGURE_DEPENDS ${md_files})
  else()
    _ln_md_files_via_glob(md_files "${md_dirs}")
  endif()

  file(RELATIVE_PATH output_shown "${CMAKE_BINARY_DIR}" "${output}")
  add_custom_command(
    OUTPUT "${output}"
    COMMAND "${CMAKE_COMMAND}" -E make_directory "${output_dir}"
    COMMAND ${command}
    DEPENDS ${md_files} ${generator_depends}
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
