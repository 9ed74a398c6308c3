# LN 2.9 projects say find_package(liblinks_and_nodes); ln_core provides the
# same CMake interface (targets liblinks_and_nodes and
# liblinks_and_nodes::liblinks_and_nodes, liblinks_and_nodes_INCLUDE_DIRS,
# liblinks_and_nodes_LIBRARIES, generate_ln_message_headers(), ...) from its
# own package "ln", installed next to this directory. Loading it here defines
# everything in the caller's scope, exactly as if find_package(ln) was called.
include(CMakeFindDependencyMacro)
find_dependency(ln CONFIG PATHS "${CMAKE_CURRENT_LIST_DIR}/../ln" NO_DEFAULT_PATH)
set(liblinks_and_nodes_FOUND TRUE)
