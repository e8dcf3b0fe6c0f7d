# What `cmake --install` puts beside the programs (each folder installs its own): the libraries
# a user's project links to speak the messages and use the models, with their headers, a CMake
# package (find_package(ptzstereo)) and a pkg-config file; the user-facing scripts.
include(CMakePackageConfigHelpers)

# ptz_relative(VAR FROM TO): the path from install folder FROM to TO, both relative to the prefix
# (an absolute TO stays absolute), so an installed tree can be moved.
function(ptz_relative var from to)
  if(IS_ABSOLUTE "${to}")
    set(${var} "${to}" PARENT_SCOPE)
  else()
    file(RELATIVE_PATH rel "/prefix/${from}" "/prefix/${to}")
    set(${var} "${rel}" PARENT_SCOPE)
  endif()
endfunction()

# Libraries, static: ptzstereo::lcmtypes (the generated headers), ptzstereo::core (rig, plant,
# config, measurements, freshness) and ptzstereo::transport (the LCM edge, message checks).
# Headers keep the paths the code includes them by: "common/rig.hpp", "ptzstereo/image_t.hpp".
set_target_properties(ptz_core PROPERTIES EXPORT_NAME core POSITION_INDEPENDENT_CODE ON)
set_target_properties(ptz_transport PROPERTIES EXPORT_NAME transport POSITION_INDEPENDENT_CODE ON)
set_target_properties(ptzstereo_lcmtypes PROPERTIES EXPORT_NAME lcmtypes)
# LCM 1.3.1's decoders need it in every user too (see the top CMakeLists.txt).
set_property(TARGET ptzstereo_lcmtypes APPEND PROPERTY INTERFACE_COMPILE_OPTIONS
  $<INSTALL_INTERFACE:-fno-strict-aliasing>)
install(TARGETS ptz_core ptz_transport ptzstereo_lcmtypes EXPORT ptzstereoTargets
  ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR})
set(PTZ_PUBLIC_HEADERS config.hpp freshness.hpp measure.hpp plant.hpp rig.hpp storage_guard.hpp)
list(TRANSFORM PTZ_PUBLIC_HEADERS PREPEND ${PROJECT_SOURCE_DIR}/common/)
install(FILES ${PTZ_PUBLIC_HEADERS} DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/ptzstereo/common)
set(PTZ_TRANSPORT_HEADERS intake.hpp message_check.hpp transport.hpp)
list(TRANSFORM PTZ_TRANSPORT_HEADERS PREPEND ${PROJECT_SOURCE_DIR}/common/transport/)
install(FILES ${PTZ_TRANSPORT_HEADERS}
  DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/ptzstereo/common/transport)

set(PTZ_CMAKE_DIR ${CMAKE_INSTALL_LIBDIR}/cmake/ptzstereo)
install(EXPORT ptzstereoTargets NAMESPACE ptzstereo:: DESTINATION ${PTZ_CMAKE_DIR})
configure_package_config_file(${CMAKE_CURRENT_LIST_DIR}/ptzstereoConfig.cmake.in
  ${CMAKE_CURRENT_BINARY_DIR}/ptzstereoConfig.cmake INSTALL_DESTINATION ${PTZ_CMAKE_DIR})
# 0.x: a new minor version may change the interfaces.
write_basic_package_version_file(${CMAKE_CURRENT_BINARY_DIR}/ptzstereoConfigVersion.cmake
  VERSION ${PROJECT_VERSION} COMPATIBILITY SameMinorVersion)
install(FILES ${CMAKE_CURRENT_BINARY_DIR}/ptzstereoConfig.cmake
  ${CMAKE_CURRENT_BINARY_DIR}/ptzstereoConfigVersion.cmake DESTINATION ${PTZ_CMAKE_DIR})

ptz_relative(PTZ_PC_TO_PREFIX ${CMAKE_INSTALL_LIBDIR}/pkgconfig .)
configure_file(${CMAKE_CURRENT_LIST_DIR}/ptzstereo.pc.in ${CMAKE_CURRENT_BINARY_DIR}/ptzstereo.pc
  @ONLY)
install(FILES ${CMAKE_CURRENT_BINARY_DIR}/ptzstereo.pc
  DESTINATION ${CMAKE_INSTALL_LIBDIR}/pkgconfig)

# The scripts a user runs, in PREFIX/share/ptzstereo/scripts (they find the programs in
# PREFIX/bin through install-paths.sh, scripts/common.sh), each also PREFIX/bin/ptzstereo-NAME.
# Not installed, for developers of the project: test, format, fuzz, bench, readme-params,
# check-layout, install-deps (they need the source tree).
set(PTZ_USER_SCRIPTS demo demo-hosts run-host run-rig replay lcm-spy check-network supervise
  calibrate-sim stability-sweep)
if(EXISTS ${PROJECT_SOURCE_DIR}/scripts/record)
  list(APPEND PTZ_USER_SCRIPTS record)
endif()
set(PTZ_SCRIPTS_DIR ${CMAKE_INSTALL_DATADIR}/ptzstereo/scripts)
set(gen ${CMAKE_CURRENT_BINARY_DIR}/installed-scripts)
ptz_relative(to_bin ${PTZ_SCRIPTS_DIR} ${CMAKE_INSTALL_BINDIR})
ptz_relative(to_java ${PTZ_SCRIPTS_DIR} ${CMAKE_INSTALL_DATADIR}/java)
file(WRITE ${gen}/install-paths.sh
  "# Written by the install: scripts/common.sh runs the installed layout; paths from this folder.\n"
  "PTZ_INSTALL_BIN=${to_bin}\nPTZ_INSTALL_JAVA=${to_java}\n")
install(FILES ${PROJECT_SOURCE_DIR}/scripts/common.sh ${gen}/install-paths.sh
  DESTINATION ${PTZ_SCRIPTS_DIR})
ptz_relative(to_scripts ${CMAKE_INSTALL_BINDIR} ${PTZ_SCRIPTS_DIR})
foreach(script ${PTZ_USER_SCRIPTS})
  install(PROGRAMS ${PROJECT_SOURCE_DIR}/scripts/${script} DESTINATION ${PTZ_SCRIPTS_DIR})
  if(IS_ABSOLUTE "${to_scripts}")
    set(target "${to_scripts}/${script}")
  else()
    set(target "$(dirname \"$(readlink -f \"$0\")\")/${to_scripts}/${script}")
  endif()
  file(WRITE ${gen}/ptzstereo-${script}
    "#!/bin/sh\n# ptzstereo's scripts/${script}, installed (--help says what it does).\n"
    "exec \"${target}\" \"$@\"\n")
  install(PROGRAMS ${gen}/ptzstereo-${script} DESTINATION ${CMAKE_INSTALL_BINDIR})
endforeach()
