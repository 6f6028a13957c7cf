# Helpers that give every project target the same rules (docs/conventions.md "Tooling").

# Warnings are errors on project code; generated code (protobuf, idlc) is built without these flags.
function(rejuv_warnings target)
  target_compile_options(${target} PRIVATE
    -Wall -Wextra -Wpedantic -Werror -Wswitch-enum -Wshadow -Wcast-align -Wnull-dereference
    -Wimplicit-fallthrough
    $<$<COMPILE_LANGUAGE:CXX>:-Wnon-virtual-dtor -Wold-style-cast -Woverloaded-virtual>)
  # The sanitizers' instrumentation at -O1 makes GCC's flow analysis report initialised members as "may be
  # used uninitialized" (PlantOptions inside a std::variant, every field with an initialiser; GCC's manual
  # warns of false positives with -fsanitize): a warning there, not an error. The default build keeps it an error.
  if(CMAKE_CXX_FLAGS MATCHES "-fsanitize=(address|thread)" AND CMAKE_CXX_COMPILER_ID STREQUAL "GNU")
    target_compile_options(${target} PRIVATE -Wno-error=maybe-uninitialized)
  endif()
endfunction()

# rejuv_library(NAME DIR [DEPS ...]): a component library with public headers under DIR/include and
# sources under DIR/src (docs/design.md §1: one target per component).
function(rejuv_library name)
  cmake_parse_arguments(ARG "HEADER_ONLY" "" "SOURCES;DEPS;PRIVATE_DEPS" ${ARGN})
  if(ARG_HEADER_ONLY)
    add_library(${name} INTERFACE)
    target_include_directories(${name} INTERFACE $<BUILD_INTERFACE:${CMAKE_CURRENT_SOURCE_DIR}/include>
                                                 $<INSTALL_INTERFACE:include>)
    target_link_libraries(${name} INTERFACE ${ARG_DEPS})
  else()
    add_library(${name} STATIC ${ARG_SOURCES})
    # The source folder in the build, the package's include folder once installed (cmake/RejuvInstall.cmake).
    target_include_directories(${name} PUBLIC $<BUILD_INTERFACE:${CMAKE_CURRENT_SOURCE_DIR}/include>
                                              $<INSTALL_INTERFACE:include>)
    target_link_libraries(${name} PUBLIC ${ARG_DEPS} PRIVATE ${ARG_PRIVATE_DEPS})
    rejuv_warnings(${name})
  endif()
endfunction()

# rejuv_gtest(NAME SOURCES ... DEPS ... [LABELS ...]): one gtest executable registered with ctest.
function(rejuv_gtest name)
  # RESOURCE_LOCK: what the executable's tests hold one at a time under ctest -j (e.g. `realtime`: real-time
  # flights share the machine's real-time budget and need their CPU time, docs/realtime.md).
  cmake_parse_arguments(ARG "" "TIMEOUT;RESOURCE_LOCK" "SOURCES;DEPS;LABELS" ${ARGN})
  add_executable(${name} ${ARG_SOURCES})
  target_link_libraries(${name} PRIVATE ${ARG_DEPS} GTest::gtest GTest::gmock GTest::gtest_main)
  target_compile_definitions(${name} PRIVATE REJUV_SOURCE_DIR="${REJUV_SOURCE_DIR}"
                                             REJUV_BINARY_DIR="${CMAKE_BINARY_DIR}")
  rejuv_warnings(${name})
  if(NOT ARG_TIMEOUT)
    set(ARG_TIMEOUT 300)
  endif()
  # A sanitizer build (CMakePresets asan, tsan: -O1, shadow memory, checks on every access) runs several times
  # slower: its per-test timeout is 4x, so that a slow test is not reported as a hang.
  # Its multi-process tests run one at a time: a real-time flight there is already several times slower than a
  # vehicle, and a second flight beside it on two cores can make a rollback miss its deadlines.
  set(serial FALSE)
  if(CMAKE_CXX_FLAGS MATCHES "-fsanitize=(address|thread)")
    math(EXPR ARG_TIMEOUT "${ARG_TIMEOUT} * 4")
    if(ARG_LABELS MATCHES "multiproc")
      set(serial TRUE)
    endif()
  endif()
  set(lock)
  if(ARG_RESOURCE_LOCK)
    set(lock RESOURCE_LOCK ${ARG_RESOURCE_LOCK})
  endif()
  include(GoogleTest)
  gtest_discover_tests(${name} PROPERTIES LABELS "${ARG_LABELS}" TIMEOUT ${ARG_TIMEOUT} RUN_SERIAL ${serial} ${lock}
                       DISCOVERY_TIMEOUT 60)
endfunction()

# rejuv_bench(NAME SOURCES ... DEPS ...): a Google Benchmark executable.
function(rejuv_bench name)
  cmake_parse_arguments(ARG "" "" "SOURCES;DEPS" ${ARGN})
  add_executable(${name} ${ARG_SOURCES})
  target_link_libraries(${name} PRIVATE ${ARG_DEPS} benchmark::benchmark)
  target_compile_definitions(${name} PRIVATE REJUV_SOURCE_DIR="${REJUV_SOURCE_DIR}")
  rejuv_warnings(${name})
endfunction()

# Service and plant executables all live in one folder the kernel knows (REJUV_SERVICE_BIN_DIR), so a
# launch graph names them by file name: `executable: "rejuv_ekf2"`.
set(REJUV_SERVICE_BIN_DIR ${CMAKE_BINARY_DIR}/bin CACHE INTERNAL "where service executables are built")
# DYNAMIC: a process of the bin folder that is no service and is never imaged (the plant, which talks DDS).
# PARAMS: the service's declared parameters (idl/params.proto; docs/writing_a_service.md "Declaring parameters"),
# one or more files, written one after the other beside the executable as <name>.params.pbtxt, where the launch
# check and `rejuv run --help-service` find them.
function(rejuv_service_executable name)
  cmake_parse_arguments(ARG "DYNAMIC" "" "SOURCES;DEPS;PARAMS" ${ARGN})
  add_executable(${name} ${ARG_SOURCES})
  if(ARG_PARAMS)
    list(TRANSFORM ARG_PARAMS PREPEND ${CMAKE_CURRENT_SOURCE_DIR}/ REGEX "^[^/]")
    list(JOIN ARG_PARAMS "|" files)
    add_custom_command(OUTPUT ${REJUV_SERVICE_BIN_DIR}/${name}.params.pbtxt
                       COMMAND ${CMAKE_COMMAND} "-DFILES=${files}" -DOUT=${REJUV_SERVICE_BIN_DIR}/${name}.params.pbtxt
                               -P ${REJUV_SOURCE_DIR}/cmake/ServiceParams.cmake
                       DEPENDS ${ARG_PARAMS} ${REJUV_SOURCE_DIR}/cmake/ServiceParams.cmake
                       COMMENT "declared parameters of ${name}" VERBATIM)
    add_custom_target(${name}_params ALL DEPENDS ${REJUV_SERVICE_BIN_DIR}/${name}.params.pbtxt)
    add_dependencies(${name} ${name}_params)
  endif()
  target_link_libraries(${name} PRIVATE ${ARG_DEPS})
  set_target_properties(${name} PROPERTIES RUNTIME_OUTPUT_DIRECTORY ${REJUV_SERVICE_BIN_DIR})
  if(REJUV_STATIC_SERVICES AND NOT ARG_DYNAMIC)  # see REJUV_STATIC_SERVICES in the top CMakeLists.txt
    set_target_properties(${name} PROPERTIES REJUV_STATIC_LINK ON)
    target_link_options(${name} PRIVATE -static)
  endif()
  rejuv_warnings(${name})
endfunction()
