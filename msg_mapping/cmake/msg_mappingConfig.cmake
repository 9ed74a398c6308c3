# find_package(msg_mapping): the ln_ros2_gen tool and msg_mapping_generate_interfaces(),
# and, where ln_core's CMake package is found too, the static library
# msg_mapping::core (the mapping and the codecs; it links ln::ln_md).
if(NOT TARGET msg_mapping::core)
  find_package(ln QUIET)
  if(TARGET ln::ln_md)
    include("${CMAKE_CURRENT_LIST_DIR}/msg_mappingTargets.cmake")
  endif()
endif()
get_filename_component(_msg_mapping_prefix "${CMAKE_CURRENT_LIST_DIR}/../../.." ABSOLUTE)
set(MSG_MAPPING_GENERATOR "${_msg_mapping_prefix}/bin/ln_ros2_gen")
if(NOT EXISTS "${MSG_MAPPING_GENERATOR}")
  set(msg_mapping_FOUND FALSE)
  set(msg_mapping_NOT_FOUND_MESSAGE "ln_ros2_gen not found at ${MSG_MAPPING_GENERATOR}")
  return()
endif()
include("${CMAKE_CURRENT_LIST_DIR}/msg_mapping_generate.cmake")
