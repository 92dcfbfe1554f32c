# GLOVE_TARGET=m7 (CMakeLists.txt): the core's unit tests, in double and float, cross-compiled for the
# Cortex-M7 and run by ctest on QEMU's mps2-an500 (test/m7/qemu_m7.sh: newlib semihosting for printf, argv and
# the exit status); glove_core_trace run on the M7 and on the host must print the same bytes (bit for bit:
# -ffp-contract=off on both); glove_core_bench counts the M7's instructions per workload against the committed
# baseline (tools/m7_counts.py, firmware/m7_counts.json).
#
# GLOVE_HOST_BUILD: the host build directory that holds glove_core_trace (make firmware builds it first).
set(GLOVE_HOST_BUILD "" CACHE PATH "host build of firmware/ with glove_core_trace")
if(NOT EXISTS "${GLOVE_HOST_BUILD}/glove_core_trace")
  message(FATAL_ERROR "GLOVE_HOST_BUILD=${GLOVE_HOST_BUILD} has no glove_core_trace: build the host first")
endif()
find_program(QEMU_ARM qemu-system-arm)
if(NOT QEMU_ARM)
  message(FATAL_ERROR "qemu-system-arm not found: apt-get install qemu-system-arm (or run make firmware)")
endif()
find_package(Python3 REQUIRED COMPONENTS Interpreter)

set(M7_DIR ${CMAKE_CURRENT_SOURCE_DIR}/test/m7)
set(CMAKE_CROSSCOMPILING_EMULATOR ${M7_DIR}/qemu_m7.sh)
add_library(m7_startup OBJECT ${M7_DIR}/startup.c)
target_compile_options(m7_startup PRIVATE -Wall -Wextra -Werror)

# an M7 program: the startup, the linker script, newlib with semihosting
function(m7_executable name src variant)
  add_executable(${name} ${src} $<TARGET_OBJECTS:m7_startup>)
  target_link_libraries(${name} PRIVATE ${variant})
  target_compile_options(${name} PRIVATE -Wall -Wextra -Werror)
  target_link_options(${name} PRIVATE --specs=rdimon.specs -T ${M7_DIR}/mps2_an500.ld)
  set_target_properties(${name} PROPERTIES SUFFIX ".elf" LINK_DEPENDS ${M7_DIR}/mps2_an500.ld)
endfunction()

enable_testing()
file(GLOB GLOVE_TESTS CONFIGURE_DEPENDS ${CMAKE_CURRENT_SOURCE_DIR}/test/host/test_*.cpp)
foreach(src ${GLOVE_TESTS})
  get_filename_component(name ${src} NAME_WE)
  foreach(variant glove_core glove_core_f32)
    string(REPLACE "glove_core" "" suffix ${variant})
    set(exe m7_${name}${suffix})
    m7_executable(${exe} ${src} ${variant})
    add_test(NAME ${exe} COMMAND ${exe})
    set_tests_properties(${exe} PROPERTIES TIMEOUT 120 PASS_REGULAR_EXPRESSION " 0 failed")
  endforeach()
endforeach()

foreach(variant glove_core glove_core_f32)
  string(REPLACE "glove_core" "" suffix ${variant})
  m7_executable(glove_core_trace${suffix} ${CMAKE_CURRENT_SOURCE_DIR}/tools/glove_core_trace.cpp ${variant})
  m7_executable(glove_core_bench${suffix} ${CMAKE_CURRENT_SOURCE_DIR}/tools/glove_core_bench.cpp ${variant})
  # the M7 and the host print the same trace, byte for byte
  add_test(NAME m7_matches_host${suffix}
           COMMAND ${CMAKE_COMMAND} -DM7=$<TARGET_FILE:glove_core_trace${suffix}> -DEMULATOR=${M7_DIR}/qemu_m7.sh
                   -DHOST=${GLOVE_HOST_BUILD}/glove_core_trace${suffix} -P ${CMAKE_CURRENT_SOURCE_DIR}/cmake/same_trace.cmake)
  set_tests_properties(m7_matches_host${suffix} PROPERTIES TIMEOUT 300)
endforeach()

# instruction counts per workload against the committed baseline: fails on a growth over 10 %
add_test(NAME m7_instruction_counts
         COMMAND ${Python3_EXECUTABLE} ${CMAKE_CURRENT_SOURCE_DIR}/tools/m7_counts.py --check --build ${CMAKE_BINARY_DIR})
set_tests_properties(m7_instruction_counts PROPERTIES TIMEOUT 600)
