# Included by the top CMakeLists.txt before any target when PTZ_FUZZ is on: every library is
# compiled with libFuzzer's coverage, AddressSanitizer and UndefinedBehaviorSanitizer (which
# aborts, so a fuzzer keeps the input); the fuzz targets add -fsanitize=fuzzer at their link.
if(NOT CMAKE_CXX_COMPILER_ID STREQUAL "Clang")
  message(FATAL_ERROR "PTZ_FUZZ needs clang (CXX=clang++-14), not ${CMAKE_CXX_COMPILER_ID}")
endif()
set(PTZ_SANITIZERS address,undefined)
add_compile_options(-fsanitize=fuzzer-no-link,${PTZ_SANITIZERS} -fno-sanitize-recover=all
  -fno-omit-frame-pointer)
add_link_options(-fsanitize=${PTZ_SANITIZERS})
