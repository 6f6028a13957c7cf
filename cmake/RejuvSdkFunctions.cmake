# The functions of the installed Rejuv package (find_package(Rejuv): RejuvConfig.cmake includes this file).
# docs/writing_a_service.md shows them in use; examples/hello_service is built with them by the `sdk` test.

# Script mode (rejuv_add_topics' POLICY step, at build time): OUT = POLICY followed by TYPES.
if(CMAKE_SCRIPT_MODE_FILE)
  file(READ "${POLICY}" policy)
  file(READ "${TYPES}" types)
  file(WRITE "${OUT}" "${policy}\n# Declared by rejuv_add_topics from the IDL as built (sizes by the compiler):\n${types}")
  return()
endif()

# rejuv_add_service(NAME SOURCES ... [LIBRARIES ...] [PARAMS file.params.pbtxt]): a service executable linked
# against Rejuv::sdk the way the project's own services are (docs/design.md §7 images: statically linked unless the SDK
# was built without REJUV_STATIC_SERVICES, so that fork() copies few mappings; no
# Cyclone DDS, no protobuf: a service reaches nothing but its channel to the kernel). The kernel starts it
# by the path a launch graph names in `executable:` (absolute, or relative to the kernel's service folder).
# PARAMS: the parameters the service declares (docs/writing_a_service.md "Declaring parameters"), copied beside
# the executable as $<TARGET_FILE:NAME>.params.pbtxt at every build; `cmake --install` installs the service and
# that file beside it in the bin folder. The kernel then refuses a launch param the file does not declare.
#
# ATTACK_HOOKS (or REJUV_ATTACK_HOOKS set true in the project, e.g. -DREJUV_ATTACK_HOOKS=ON for a test build)
# links Rejuv::sdk_attack as well, which defines REJUV_ATTACK_HOOKS: the CUSTOM attack hook of
# rejuv/sdk/attack_hook.hpp (docs/writing_a_service.md "Injecting a fault into your own service"). Never in a
# build that flies for real: the hook is how a test injects a fault.
function(rejuv_add_service name)
  cmake_parse_arguments(ARG "ATTACK_HOOKS" "PARAMS" "SOURCES;LIBRARIES" ${ARGN})
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
  if(ARG_ATTACK_HOOKS OR REJUV_ATTACK_HOOKS)
    target_link_libraries(${name} PRIVATE Rejuv::sdk_attack)
  endif()
  if(ARG_PARAMS)
    get_filename_component(params "${ARG_PARAMS}" ABSOLUTE)
    add_custom_target(${name}_params ALL
                      COMMAND ${CMAKE_COMMAND} -E copy_if_different ${params} $<TARGET_FILE:${name}>.params.pbtxt
                      DEPENDS ${params}
                      COMMENT "declared parameters of ${name}: $<TARGET_FILE_NAME:${name}>.params.pbtxt" VERBATIM)
    add_dependencies(${name}_params ${name})
    set(bindir bin)
    if(CMAKE_INSTALL_BINDIR)
      set(bindir ${CMAKE_INSTALL_BINDIR})
    endif()
    install(TARGETS ${name} RUNTIME DESTINATION ${bindir})
    install(FILES ${params} DESTINATION ${bindir} RENAME ${name}.params.pbtxt)  # the executable is NAME (Linux)
  endif()
endfunction()

# rejuv_add_topics(NAME FILES a.idl ... TYPES module::Struct ... [POLICY p.policy.pbtxt]): topic types of your own IDL, beside the
# project's (docs/writing_a_service.md "A new topic type"). Cyclone's idlc makes C structs of FILES: link
# the static library NAME and include "<idl file name>.h". For each of TYPES (IDL scoped names; the C
# struct is the name with "::" as "_"), the program NAME_types, run at build time, writes the policy's
# `types` entry — name, size_bytes, align_bytes as the compiler laid the struct out — to
# <build>/NAME.types.pbtxt: the policy declares exactly these (the kernel sizes the topic's ring by them and
# the SDK refuses a struct of another size). Such a topic is routed between services; it is not bridged to
# DDS. In the service, `REJUV_TOPIC_TYPE(module_Struct, "module::Struct")` (rejuv/msgs/topic_types.hpp)
# lets advertise<>/subscribe<> name it. With POLICY, <build>/<its file name> is that policy with these
# entries appended, rewritten whenever the IDL changes.
function(rejuv_add_topics name)
  cmake_parse_arguments(ARG "" "POLICY" "FILES;TYPES" ${ARGN})
  if(NOT ARG_FILES OR NOT ARG_TYPES)
    message(FATAL_ERROR "rejuv_add_topics(${name}): FILES (the .idl) and TYPES (module::Struct ...) are required")
  endif()
  idlc_generate(TARGET ${name}_gen FILES ${ARG_FILES} DEFAULT_EXTENSIBILITY final)
  get_target_property(sources ${name}_gen INTERFACE_SOURCES)
  add_library(${name} STATIC ${sources})
  add_dependencies(${name} ${name}_gen_generate)
  target_include_directories(${name} SYSTEM PUBLIC ${CMAKE_CURRENT_BINARY_DIR})
  target_link_libraries(${name} PUBLIC Rejuv::msgs_c)  # the DDS headers idlc's C includes
  set(includes "")
  foreach(file IN LISTS ARG_FILES)
    get_filename_component(stem "${file}" NAME_WE)
    string(APPEND includes "#include \"${stem}.h\"\n")
  endforeach()
  set(lines "")
  foreach(type IN LISTS ARG_TYPES)
    if(NOT type MATCHES "^[A-Za-z_][A-Za-z0-9_]*(::[A-Za-z_][A-Za-z0-9_]*)+$")
      message(FATAL_ERROR "rejuv_add_topics(${name}): '${type}' is not an IDL scoped name (module::Struct)")
    endif()
    string(REPLACE "::" "_" ctype "${type}")
    string(APPEND lines "  std::fprintf(out, \"types { name: \\\"${type}\\\" size_bytes: %zu align_bytes: %zu }\\n\", sizeof(${ctype}), alignof(${ctype}));\n")
  endforeach()
  file(GENERATE OUTPUT ${CMAKE_CURRENT_BINARY_DIR}/${name}_types.cpp
       CONTENT "// Generated by rejuv_add_topics(${name}): the policy's `types` entries for these structs, to argv[1].\n#include <cstdio>\n${includes}int main(int argc, char** argv) {\n  std::FILE* out = argc == 2 ? std::fopen(argv[1], \"w\") : nullptr;\n  if (out == nullptr) return 1;\n${lines}  return std::fclose(out) == 0 ? 0 : 1;\n}\n")
  add_executable(${name}_types ${CMAKE_CURRENT_BINARY_DIR}/${name}_types.cpp)
  target_compile_features(${name}_types PRIVATE cxx_std_17)
  target_link_libraries(${name}_types PRIVATE ${name})
  add_custom_command(OUTPUT ${CMAKE_CURRENT_BINARY_DIR}/${name}.types.pbtxt
                     COMMAND ${name}_types ${CMAKE_CURRENT_BINARY_DIR}/${name}.types.pbtxt
                     DEPENDS ${name}_types
                     COMMENT "policy `types` of ${name}: ${name}.types.pbtxt" VERBATIM)
  set(outputs ${CMAKE_CURRENT_BINARY_DIR}/${name}.types.pbtxt)
  if(ARG_POLICY)
    get_filename_component(policy "${ARG_POLICY}" ABSOLUTE)
    get_filename_component(policy_name "${ARG_POLICY}" NAME)
    add_custom_command(OUTPUT ${CMAKE_CURRENT_BINARY_DIR}/${policy_name}
                       COMMAND ${CMAKE_COMMAND} -DPOLICY=${policy} -DTYPES=${CMAKE_CURRENT_BINARY_DIR}/${name}.types.pbtxt
                               -DOUT=${CMAKE_CURRENT_BINARY_DIR}/${policy_name} -P ${CMAKE_CURRENT_FUNCTION_LIST_FILE}
                       DEPENDS ${policy} ${CMAKE_CURRENT_BINARY_DIR}/${name}.types.pbtxt
                       COMMENT "${policy_name} with the `types` of ${name}" VERBATIM)
    list(APPEND outputs ${CMAKE_CURRENT_BINARY_DIR}/${policy_name})
  endif()
  add_custom_target(${name}_policy_types ALL DEPENDS ${outputs})
endfunction()
