# GLOVE_TARGET=host (CMakeLists.txt): the core's unit tests, the host tools and the Arduino layer's compile check.

# ---- unit tests: one executable per file under test/host, a tiny harness (test/host/check.h)
enable_testing()
file(GLOB GLOVE_TESTS CONFIGURE_DEPENDS ${PROJECT_SOURCE_DIR}/test/host/test_*.cpp)
foreach(src ${GLOVE_TESTS})
  get_filename_component(name ${src} NAME_WE)
  foreach(variant glove_core glove_core_f32)
    set(exe ${name})
    if(variant STREQUAL "glove_core_f32")
      set(exe ${name}_f32)
    endif()
    add_executable(${exe} ${src})
    target_link_libraries(${exe} PRIVATE ${variant})
    target_compile_options(${exe} PRIVATE -Wall -Wextra -Werror)
    add_test(NAME ${exe} COMMAND ${exe})
    set_tests_properties(${exe} PROPERTIES TIMEOUT 30)
  endforeach()
endforeach()

# The same unit tests under valgrind memcheck, when valgrind is installed: uninitialised reads, overruns.
find_program(VALGRIND valgrind)
if(VALGRIND)
  foreach(name test_filter test_hand test_glove test_protocol)
    # --show-mismatched-frees=no: test_glove replaces operator new to count allocations
    add_test(NAME memcheck_${name} COMMAND ${VALGRIND} --quiet --error-exitcode=99 --track-origins=yes
             --show-mismatched-frees=no $<TARGET_FILE:${name}>)
    set_tests_properties(memcheck_${name} PROPERTIES TIMEOUT 60)
  endforeach()
endif()

# The core must not allocate or pull in the heavy parts of the standard library.
add_test(NAME core_is_allocation_free
         COMMAND ${CMAKE_COMMAND} -DDIR=${GLOVE_CORE_DIR} -P ${PROJECT_SOURCE_DIR}/cmake/check_core.cmake)

# ---- host tools
add_executable(glove_core_cli tools/glove_core_cli.cpp)
target_link_libraries(glove_core_cli PRIVATE glove_core)
target_compile_options(glove_core_cli PRIVATE -Wall -Wextra -Werror)

# the callgrind workload of bench/firmware.py, and the trace the M7 build must reproduce bit for bit
# (cmake/m7.cmake), in double (default) and float
foreach(variant glove_core glove_core_f32)
  string(REPLACE "glove_core" "" suffix ${variant})
  foreach(tool glove_core_bench glove_core_trace)
    add_executable(${tool}${suffix} tools/${tool}.cpp)
    target_link_libraries(${tool}${suffix} PRIVATE ${variant})
    target_compile_options(${tool}${suffix} PRIVATE -Wall -Wextra -Werror)
  endforeach()
endforeach()

# ---- the Arduino layer (src/) compiled, not linked, against header-only stubs of Arduino and Wire: catches type
# and API slips without the ARM toolchain (GLOVE_TARGET=teensy40 builds it against the real Teensyduino core).
option(GLOVE_CHECK_ARDUINO_LAYER "Compile firmware/src against test/host_stubs" ON)
if(GLOVE_CHECK_ARDUINO_LAYER)
  file(GLOB GLOVE_ARDUINO_SOURCES CONFIGURE_DEPENDS ${PROJECT_SOURCE_DIR}/src/*.cpp)
  if(NOT GLOVE_ARDUINO_SOURCES)
    message(FATAL_ERROR "no Arduino sources in ${PROJECT_SOURCE_DIR}/src")
  endif()
  # the thesis' 12-IMU glove on USB serial, and the 16-IMU variant on a UART
  foreach(check arduino_layer_check arduino_layer_check_16)
    add_library(${check} OBJECT ${GLOVE_ARDUINO_SOURCES})
    target_include_directories(${check} PRIVATE
      ${PROJECT_SOURCE_DIR}/test/host_stubs ${PROJECT_SOURCE_DIR}/src ${GLOVE_CORE_DIR})
    target_compile_options(${check} PRIVATE ${GLOVE_WARNINGS} -fno-exceptions -fno-rtti)
  endforeach()
  target_compile_definitions(arduino_layer_check_16 PRIVATE GLOVE_N_IMU=16 GLOVE_SERIAL=Serial1 GLOVE_MODE=3)
endif()
