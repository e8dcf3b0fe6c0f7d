# Precompiled headers: the standard library, Eigen and OpenCV's core are included by most of the
# ~400 translation units, and parsing them was most of a first build's time. Two headers are
# compiled once each (one for position-independent code, one without: GCC refuses a .gch made with
# other code-model flags) and every target reuses the one that matches it.
# Measured on 2 cores, the demo's programs from a new build dir: 191 s with make and no .gch,
# 155 s with them, 142 s with them and Ninja.
option(PTZ_PCH "Precompile the common headers (the standard library, Eigen, OpenCV core)" ON)

set(PTZ_PCH_HEADERS
    <algorithm> <array> <atomic> <chrono> <cmath> <cstdint> <cstring> <functional> <map>
    <memory> <mutex> <optional> <sstream> <string> <thread> <unordered_map> <utility> <vector>
    <Eigen/Core> <Eigen/Geometry> <opencv2/core.hpp> <opencv2/imgproc.hpp>)

# ptz_targets_under(DIR OUT): every target defined in DIR and the directories below it.
function(ptz_targets_under dir out)
  get_property(targets DIRECTORY ${dir} PROPERTY BUILDSYSTEM_TARGETS)
  get_property(subdirs DIRECTORY ${dir} PROPERTY SUBDIRECTORIES)
  foreach(sub IN LISTS subdirs)
    ptz_targets_under(${sub} below)
    list(APPEND targets ${below})
  endforeach()
  set(${out} ${targets} PARENT_SCOPE)
endfunction()

# ptz_precompile_headers(): call last, when every target and its PIC property are known.
function(ptz_precompile_headers)
  # The fuzz build instruments with clang's sanitizers: no shared .gch there.
  if(NOT PTZ_PCH OR PTZ_FUZZ)
    return()
  endif()
  set(source ${CMAKE_BINARY_DIR}/pch/pch.cpp)
  if(NOT EXISTS ${source})  # written once: a new time stamp would rebuild it at each configure
    file(WRITE ${source} "// the precompiled headers' own translation unit\n")
  endif()
  foreach(pch ptz_pch ptz_pch_pic)
    add_library(${pch} STATIC ${source})
    target_link_libraries(${pch} PRIVATE Eigen3::Eigen opencv_core opencv_imgproc)
    # -pthread as LCM's pkg-config flags: GCC refuses a .gch made without its _REENTRANT.
    target_compile_options(${pch} PRIVATE -pthread)
    target_precompile_headers(${pch} PRIVATE ${PTZ_PCH_HEADERS})
  endforeach()
  set_target_properties(ptz_pch_pic PROPERTIES POSITION_INDEPENDENT_CODE ON)

  ptz_targets_under(${CMAKE_SOURCE_DIR} targets)
  foreach(target IN LISTS targets)
    get_target_property(type ${target} TYPE)
    if(NOT type MATCHES "^(STATIC_LIBRARY|SHARED_LIBRARY|MODULE_LIBRARY|EXECUTABLE)$"
       OR target MATCHES "^ptz_pch")
      continue()
    endif()
    get_target_property(pic ${target} POSITION_INDEPENDENT_CODE)
    if(type MATCHES "SHARED|MODULE" OR pic)
      set(pch ptz_pch_pic)
    else()
      set(pch ptz_pch)
    endif()
    target_precompile_headers(${target} REUSE_FROM ${pch})
    # The headers' include paths in every target, as system ones: a warning inside Eigen is not
    # ours, and the .gch is only used where its include paths are found.
    target_include_directories(${target} SYSTEM PRIVATE ${EIGEN3_INCLUDE_DIRS} ${OpenCV_INCLUDE_DIRS})
    target_compile_options(${target} PRIVATE -pthread)
  endforeach()
endfunction()
