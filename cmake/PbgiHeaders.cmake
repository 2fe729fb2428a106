# pbgi_headers(<target> [FILES <header>...]): the headers of the calling
# folder, for <target> and what links it, and for nothing else.
#
# Every header is included by its path from the repository root
# ("storage/tree/node.h"), but the root itself is on no include path: each
# library gets a directory of its own under the build tree holding one
# link, named after its folder's path, to that folder
# (<build>/include/pbgi_storage_tree/storage/tree -> storage/tree), and that
# directory is on the library's PUBLIC (INTERFACE, for a header-only
# library) include path. So "storage/tree/node.h" compiles only in a target
# that links pbgi_storage_tree: the build enforces that a target includes
# only what it links, and the link graph is the layer graph
# (scripts/check_layers.py checks its direction).
#
# FILES exposes only the named headers of the folder, for a folder whose
# subfolders are libraries of their own (common/).
function(pbgi_headers target)
  cmake_parse_arguments(H "" "" "FILES" ${ARGN})
  file(RELATIVE_PATH folder ${PROJECT_SOURCE_DIR} ${CMAKE_CURRENT_SOURCE_DIR})
  set(root ${PROJECT_BINARY_DIR}/include/${target})
  if(H_FILES)
    file(MAKE_DIRECTORY ${root}/${folder})
    foreach(f IN LISTS H_FILES)
      if(NOT EXISTS ${CMAKE_CURRENT_SOURCE_DIR}/${f})
        message(FATAL_ERROR "pbgi_headers(${target}): ${folder}/${f} does not exist")
      endif()
      file(CREATE_LINK ${CMAKE_CURRENT_SOURCE_DIR}/${f} ${root}/${folder}/${f} SYMBOLIC)
    endforeach()
  else()
    get_filename_component(parent ${root}/${folder} DIRECTORY)
    file(MAKE_DIRECTORY ${parent})
    file(CREATE_LINK ${CMAKE_CURRENT_SOURCE_DIR} ${root}/${folder} SYMBOLIC)
  endif()
  get_target_property(type ${target} TYPE)
  if(type STREQUAL "INTERFACE_LIBRARY")
    target_include_directories(${target} INTERFACE ${root})
  else()
    target_include_directories(${target} PUBLIC ${root})
  endif()
endfunction()
