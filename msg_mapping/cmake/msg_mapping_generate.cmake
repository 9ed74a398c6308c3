# msg_mapping_generate_interfaces(): ROS 2 interfaces of LN message definitions,
# inside one ament_cmake package, regenerated whenever a definition changes.
#
#   find_package(ament_cmake REQUIRED)
#   find_package(rosidl_default_generators REQUIRED)
#   find_package(msg_mapping REQUIRED)
#   msg_mapping_generate_interfaces(
#     MD_DIRS ${CMAKE_CURRENT_SOURCE_DIR}/defs      # LN search path (--md-dir)
#     DEFINITIONS my_robot/pose my_robot/move       # and/or
#     RECURSIVE ${CMAKE_CURRENT_SOURCE_DIR}/defs    # every definition under a directory
#     [RULES rules.yaml]                            # validated rule files
#     [GENERATE_ONLY]                               # skip rosidl_generate_interfaces
#     [OUTPUT_VARIABLE var])                        # receives the generated interface tuples
#   ament_package()
#
# All types go into this package (ln_ros2_gen --package ${PROJECT_NAME}); type
# names come from the whole LN name (my_robot/pose -> MyRobotPose). The
# generator runs at configure time; every definition file it read, the rule
# files and the RECURSIVE directories' contents are configure dependencies, so
# editing, adding or removing a definition re-runs it on the next build. The
# pairing is installed as share/${PROJECT_NAME}/ln_mapping.json.
function(msg_mapping_generate_interfaces)
  cmake_parse_arguments(ARG "GENERATE_ONLY" "OUTPUT_VARIABLE" "DEFINITIONS;RECURSIVE;MD_DIRS;RULES" ${ARGN})
  if(ARG_UNPARSED_ARGUMENTS)
    message(FATAL_ERROR "msg_mapping_generate_interfaces: unknown arguments ${ARG_UNPARSED_ARGUMENTS}")
  endif()
  if(NOT MSG_MAPPING_GENERATOR)
    message(FATAL_ERROR "msg_mapping_generate_interfaces: MSG_MAPPING_GENERATOR is not set (find_package(msg_mapping))")
  endif()
  set(out "${CMAKE_CURRENT_BINARY_DIR}/msg_mapping_interfaces")
  set(depfile "${CMAKE_CURRENT_BINARY_DIR}/msg_mapping_interfaces.deps")
  set(args --package "${PROJECT_NAME}" --out "${out}" --depfile "${depfile}")
  foreach(dir IN LISTS ARG_MD_DIRS)
    list(APPEND args --md-dir "${dir}")
  endforeach()
  foreach(dir IN LISTS ARG_RECURSIVE)
    list(APPEND args --recursive "${dir}")
    # New or deleted definition files change the set of types.
    file(GLOB_RECURSE _msg_mapping_listing CONFIGURE_DEPENDS LIST_DIRECTORIES false "${dir}/*")
  endforeach()
  foreach(rules IN LISTS ARG_RULES)
    list(APPEND args --rules "${rules}")
  endforeach()
  execute_process(COMMAND ${MSG_MAPPING_GENERATOR} ${args} ${ARG_DEFINITIONS}
                  RESULT_VARIABLE rc OUTPUT_VARIABLE output ERROR_VARIABLE error)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "msg_mapping_generate_interfaces: ln_ros2_gen failed (${rc}):\n${error}${output}")
  endif()
  file(STRINGS "${depfile}" inputs)
  set_property(DIRECTORY APPEND PROPERTY CMAKE_CONFIGURE_DEPENDS ${inputs} ${ARG_RULES})

  set(package_dir "${out}/${PROJECT_NAME}")
  file(GLOB interface_files RELATIVE "${package_dir}" "${package_dir}/msg/*.msg" "${package_dir}/srv/*.srv")
  list(SORT interface_files)
  set(tuples "")
  foreach(file IN LISTS interface_files)
    list(APPEND tuples "${package_dir}:${file}")
  endforeach()
  if(ARG_OUTPUT_VARIABLE)
    set(${ARG_OUTPUT_VARIABLE} "${tuples}" PARENT_SCOPE)
  endif()
  if(NOT ARG_GENERATE_ONLY)
    rosidl_generate_interfaces(${PROJECT_NAME} ${tuples})
    install(FILES "${package_dir}/ln_mapping.json" DESTINATION "share/${PROJECT_NAME}")
    ament_export_dependencies(rosidl_default_runtime)
  endif()
endfunction()
