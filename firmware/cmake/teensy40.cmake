# GLOVE_TARGET=teensy40 (CMakeLists.txt): the Teensy 4.0 firmware image, without PlatformIO, against the
# unmodified Teensyduino 1.59 core and Wire in ../shared/third_party (its README gives the flags used here).
# Builds glove.hex (12 IMUs, USB serial: the thesis glove) and, to keep them compiling, the other two
# configurations of platformio.ini: glove_16imu.hex and glove_uart.hex. Prints each image's size
# (tools/teensy_size.py) and writes it to size.json.
enable_language(ASM)
set(TEENSY_SOURCES "${PROJECT_SOURCE_DIR}/../../shared/third_party" CACHE PATH "Teensyduino core and Wire")
if(NOT EXISTS "${TEENSY_SOURCES}/teensy4/imxrt1062.ld" OR NOT EXISTS "${TEENSY_SOURCES}/Wire/WireIMXRT.cpp")
  message(FATAL_ERROR "no Teensyduino core and Wire at ${TEENSY_SOURCES} (set TEENSY_SOURCES)")
endif()
find_package(Python3 REQUIRED COMPONENTS Interpreter)
set(T ${TEENSY_SOURCES})

# the Teensyduino core and Wire: third-party code, built with its own flags and no warnings of ours
file(GLOB teensy_core_sources ${T}/teensy4/*.c ${T}/teensy4/*.cpp ${T}/teensy4/*.S)
add_library(teensy_core STATIC ${teensy_core_sources} ${T}/Wire/Wire.cpp ${T}/Wire/WireIMXRT.cpp)
target_include_directories(teensy_core SYSTEM PUBLIC ${T}/teensy4 ${T}/Wire)
target_compile_definitions(teensy_core PUBLIC __IMXRT1062__ TEENSYDUINO=159 ARDUINO=10813 ARDUINO_TEENSY40
                           F_CPU=600000000 USB_SERIAL LAYOUT_US_ENGLISH)
target_compile_options(teensy_core PRIVATE -w $<$<COMPILE_LANGUAGE:CXX>:-fpermissive -felide-constructors>)
set_target_properties(teensy_core PROPERTIES CXX_EXTENSIONS ON)  # gnu++17, as Teensyduino: its headers need it
set(glove_cxx_flags -fno-exceptions -fno-rtti -fno-threadsafe-statics)
target_compile_options(teensy_core PUBLIC $<$<COMPILE_LANGUAGE:CXX>:${glove_cxx_flags}>)

file(GLOB glove_sources CONFIGURE_DEPENDS ${PROJECT_SOURCE_DIR}/src/*.cpp)
set(images glove glove_16imu glove_uart)
set(glove_16imu_defs GLOVE_N_IMU=16)
set(glove_uart_defs GLOVE_SERIAL=Serial1 GLOVE_MODE=3)
foreach(image ${images})
  add_executable(${image} ${glove_sources})
  target_include_directories(${image} PRIVATE ${PROJECT_SOURCE_DIR}/src)
  target_compile_definitions(${image} PRIVATE ${${image}_defs})
  target_compile_options(${image} PRIVATE ${GLOVE_WARNINGS})
  target_link_libraries(${image} PRIVATE glove_core teensy_core m stdc++)
  target_link_options(${image} PRIVATE -Wl,--relax -T ${T}/teensy4/imxrt1062.ld)
  set_target_properties(${image} PROPERTIES SUFFIX ".elf" LINK_DEPENDS ${T}/teensy4/imxrt1062.ld CXX_EXTENSIONS ON)
  add_custom_command(TARGET ${image} POST_BUILD
    COMMAND ${CMAKE_OBJCOPY} -O ihex -R .eeprom $<TARGET_FILE:${image}> ${image}.hex
    COMMAND ${Python3_EXECUTABLE} ${PROJECT_SOURCE_DIR}/tools/teensy_size.py $<TARGET_FILE:${image}>
            --json ${image}.size.json
    WORKING_DIRECTORY ${CMAKE_BINARY_DIR} VERBATIM)
endforeach()
