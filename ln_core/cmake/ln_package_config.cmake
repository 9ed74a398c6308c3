# Installs the CMake package so that user projects find us both as
# find_package(ln) and under LN 2.9's name find_package(liblinks_and_nodes).
#
# Include this file after every target it should export is defined: ln_md
# always, and the client library target `ln` (exported as ln::ln) once it
# exists -- `if(TARGET ln)` is evaluated when this file is included.
include(CMakePackageConfigHelpers)
set(LN_CMAKE_INSTALL_DIR ${CMAKE_INSTALL_LIBDIR}/cmake/ln)

# The version of LN whose CMake interface the liblinks_and_nodes package
# name stands for (LN 2.9's own package has no version file at all).
set(LN_COMPAT_VERSION 2.9.0)

set(_ln_export_targets ln_md)
set(LN_CONFIG_NEEDS_THREADS OFF)
if(TARGET ln)
  list(APPEND _ln_export_targets ln)
  get_target_property(_ln_interface_links ln INTERFACE_LINK_LIBRARIES)
  if(_ln_interface_links MATCHES "Threads::Threads")
    set(LN_CONFIG_NEEDS_THREADS ON)
  endif()
  unset(_ln_interface_links)
endif()

install(TARGETS ${_ln_export_targets} EXPORT lnTargets
  ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
  LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}
  RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR}
  INCLUDES DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
install(EXPORT lnTargets NAMESPACE ln:: DESTINATION ${LN_CMAKE_INSTALL_DIR})

configure_package_config_file(cmake/lnConfig.cmake.in
  ${CMAKE_CURRENT_BINARY_DIR}/lnConfig.cmake
  INSTALL_DESTINATION ${LN_CMAKE_INSTALL_DIR}
  PATH_VARS CMAKE_INSTALL_BINDIR CMAKE_INSTALL_DATADIR CMAKE_INSTALL_INCLUDEDIR)
write_basic_package_version_file(${CMAKE_CURRENT_BINARY_DIR}/lnConfigVersion.cmake
  COMPATIBILITY SameMajorVersion)
install(FILES
  ${CMAKE_CURRENT_BINARY_DIR}/lnConfig.cmake
  ${CMAKE_CURRENT_BINARY_DIR}/lnConfigVersion.cmake
  cmake/ln_generate_headers.cmake
  cmake/ln_build_helpers.cmake
  DESTINATION ${LN_CMAKE_INSTALL_DIR})

# LN 2.9's package name: a thin forwarder to lnConfig.cmake, versioned as the
# LN release whose interface it reproduces.
write_basic_package_version_file(
  ${CMAKE_CURRENT_BINARY_DIR}/liblinks_and_nodes-config-version.cmake
  VERSION ${LN_COMPAT_VERSION}
  COMPATIBILITY SameMajorVersion)
install(FILES
  cmake/liblinks_and_nodes-config.cmake
  ${CMAKE_CURRENT_BINARY_DIR}/liblinks_and_nodes-config-version.cmake
  DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/liblinks_and_nodes)

# A target `ln` defined after this point would silently be missing from the
# package; say so (cmake_language(DEFER) exists from CMake 3.19 on).
if(NOT TARGET ln AND NOT CMAKE_VERSION VERSION_LESS 3.19)
  function(_ln_check_late_client_target)
    if(TARGET ln)
      message(WARNING "ln_package_config.cmake was included before the target `ln` was "
        "defined, so ln::ln is not exported; include it after add_library(ln ...)")
    endif()
  endfunction()
  cmake_language(DEFER CALL _ln_check_late_client_target)
endif()
unset(_ln_export_targets)
