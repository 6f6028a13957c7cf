# The functions of the installed Rejuv package (find_package(Rejuv): RejuvConfig.cmake includes this file).
# docs/writing_a_service.md shows them in use; examples/hello_service is built with them by the `sdk` test.

# rejuv_add_service(NAME SOURCES ... [LIBRARIES ...]): a service executable linked against Rejuv::sdk the way
# the project's own services are (DESIGN §7 images: statically linked unless the SDK was built without
# REJUV_STATIC_SERVICES, so that fork() copies few mappings; no
# Cyclone DDS, no protobuf: a service reaches nothing but its channel to the kernel). The kernel starts it
# by the path a launch graph names in `executable:` (absolute, or relative to the kernel's service folder).
function(rejuv_add_service name)
  cmake_parse_arguments(ARG "" "" "SOURCES;LIBRARIES" ${ARGN})
  if(NOT ARG_SOURCES)
    message(FATAL_ERROR "rejuv_add_service(${name}): no SOURCES")
  endif()
  add_executable(${name} ${ARG_SOURCES})
  target_compile_features(${name} PRIVATE cxx_std_23)
  set_target_properties(${name} PROPERTIES CXX_EXTENSIONS OFF)
  if(REJUV_STATIC_SERVICES)  # RejuvConfig.cmake: as the package's own services were linked
    set_target_properties(${name} PROPERTIES REJUV_STATIC_LINK ON)
    target_link_options(${name} PRIVATE -static)
  endif()
  target_link_libraries(${name} PRIVATE Rejuv::sdk ${ARG_LIBRARIES})
endfunction()
