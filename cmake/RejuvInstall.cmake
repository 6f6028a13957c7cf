# `cmake --install <build> --component sdk [--prefix DIR]`: the service SDK as a package
# (docs/writing_a_service.md). Installs the SDK's headers and static libraries, the IDL of the topic types,
# and a CMake package: find_package(Rejuv) gives Rejuv::sdk and rejuv_add_service().
include(GNUInstallDirs)
include(CMakePackageConfigHelpers)

# What a service links (the closure of rejuv_sdk): no protobuf, no Cyclone DDS library, no simulation.
# rejuv_sdk_attack: the CUSTOM attack hook, linked by a service's test build only (rejuv_add_service ATTACK_HOOKS).
set(REJUV_SDK_TARGETS rejuv_sdk rejuv_core rejuv_channel rejuv_clock rejuv_sys rejuv_cap rejuv_memory_image
    rejuv_msgs rejuv_msgs_c rejuv_sdk_attack)
foreach(target IN LISTS REJUV_SDK_TARGETS)
  string(REGEX REPLACE "^rejuv_" "" short ${target})
  set_target_properties(${target} PROPERTIES EXPORT_NAME ${short})
endforeach()
install(TARGETS ${REJUV_SDK_TARGETS} EXPORT RejuvTargets
        ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR} COMPONENT sdk
        INCLUDES DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
foreach(dir kernel_sim/core kernel_sim/channel kernel_sim/clock kernel_sim/sys kernel_sim/cap services/sdk idl)
  install(DIRECTORY ${PROJECT_SOURCE_DIR}/${dir}/include/ DESTINATION ${CMAKE_INSTALL_INCLUDEDIR} COMPONENT sdk
          FILES_MATCHING PATTERN "*.hpp" PATTERN "*.h")
endforeach()
# The C structs idlc made of idl/*.idl (topic_types.hpp includes them by bare name).
install(DIRECTORY ${PROJECT_BINARY_DIR}/idl/ DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/rejuv/idl COMPONENT sdk
        FILES_MATCHING PATTERN "*.h" PATTERN "CMakeFiles" EXCLUDE PATTERN "*.pb.h" EXCLUDE)
set(REJUV_INSTALL_IDLDIR ${CMAKE_INSTALL_DATADIR}/rejuv/idl)
install(FILES ${PROJECT_SOURCE_DIR}/idl/sensors.idl ${PROJECT_SOURCE_DIR}/idl/state.idl
              ${PROJECT_SOURCE_DIR}/idl/control.idl ${PROJECT_SOURCE_DIR}/idl/sr.idl ${PROJECT_SOURCE_DIR}/idl/sim.idl
        DESTINATION ${REJUV_INSTALL_IDLDIR} COMPONENT sdk)

# The project's graphs and policy, for an out-of-tree graph to include (docs/writing_a_service.md "Graph
# fragments"): share/rejuv/launch/hover.launch.pbtxt names ../policies/quad_sr.policy.pbtxt as in the tree.
set(REJUV_INSTALL_LAUNCHDIR ${CMAKE_INSTALL_DATADIR}/rejuv/launch)
install(FILES ${PROJECT_SOURCE_DIR}/launch/hover.launch.pbtxt
              ${PROJECT_SOURCE_DIR}/launch/quad_square_paper.launch.pbtxt ${PROJECT_SOURCE_DIR}/launch/quad_square.launch.pbtxt
        DESTINATION ${REJUV_INSTALL_LAUNCHDIR} COMPONENT sdk)
install(FILES ${PROJECT_SOURCE_DIR}/policies/quad_sr.policy.pbtxt
        DESTINATION ${CMAKE_INSTALL_DATADIR}/rejuv/policies COMPONENT sdk)

set(REJUV_CMAKE_DIR ${CMAKE_INSTALL_LIBDIR}/cmake/Rejuv)
# The `rejuv` program built beside this SDK (the kernel and the services of the package's graphs): a service's
# test flies its graph with it, so the package names it (REJUV_PACKAGE_PROGRAM in RejuvConfig.cmake).
file(GENERATE OUTPUT ${PROJECT_BINARY_DIR}/RejuvProgram.cmake
     CONTENT "# Written by the build of the Rejuv tree this package was installed from.\nset(REJUV_PACKAGE_PROGRAM \"$<TARGET_FILE:rejuv>\")\n")
install(EXPORT RejuvTargets NAMESPACE Rejuv:: DESTINATION ${REJUV_CMAKE_DIR} COMPONENT sdk)
configure_package_config_file(${PROJECT_SOURCE_DIR}/cmake/RejuvConfig.cmake.in
                              ${PROJECT_BINARY_DIR}/RejuvConfig.cmake
                              INSTALL_DESTINATION ${REJUV_CMAKE_DIR}
                              PATH_VARS REJUV_INSTALL_IDLDIR REJUV_INSTALL_LAUNCHDIR)
write_basic_package_version_file(${PROJECT_BINARY_DIR}/RejuvConfigVersion.cmake
                                 VERSION ${PROJECT_VERSION} COMPATIBILITY SameMinorVersion)
install(FILES ${PROJECT_BINARY_DIR}/RejuvConfig.cmake ${PROJECT_BINARY_DIR}/RejuvConfigVersion.cmake
              ${PROJECT_BINARY_DIR}/RejuvProgram.cmake ${PROJECT_SOURCE_DIR}/cmake/RejuvSdkFunctions.cmake
        DESTINATION ${REJUV_CMAKE_DIR} COMPONENT sdk)
