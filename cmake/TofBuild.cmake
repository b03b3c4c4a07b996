# Build helpers shared by every folder: warnings, sanitizers, per-core
# component libraries and firmware images with their checks.

# --- warnings: errors on every target --------------------------------------
add_library(tof_warnings INTERFACE)
target_compile_options(tof_warnings INTERFACE
  -Wall -Wextra -Werror -Wconversion -Wsign-conversion -Wshadow -Wundef
  -Wcast-align -Wpointer-arith -Wformat=2 -Wnull-dereference -Wdouble-promotion
  $<$<COMPILE_LANGUAGE:C>:-Wstrict-prototypes -Wmissing-prototypes -Wold-style-definition>)

# --- cores (cross builds): one interface target of flags per core ----------
if(CMAKE_CROSSCOMPILING)
  # A board's capacity choices (estimators built, window rows), the same for every
  # component of its preset: set by the board layer of the toolchain.
  if(TOF_BOARD_DEFINITIONS)
    add_compile_definitions(${TOF_BOARD_DEFINITIONS})
  endif()
  # Optimisation of every cross-built object: -Os (size) unless the preset says otherwise.
  set(TOF_OPT_FLAGS -Os CACHE STRING "Optimisation flags of the cross builds")
  # Link-time optimisation of the images (a board layer's TOF_LTO_DEFAULT: the flight boards;
  # the QEMU benchmark images stay without, so their instruction counts measure the code as
  # compiled file by file). Code generation then happens at the link, with the same flags;
  # the stack check reads the call graphs GCC writes for the link's partitions.
  if(NOT DEFINED TOF_LTO_DEFAULT)
    set(TOF_LTO_DEFAULT OFF)
  endif()
  option(TOF_LTO "Link-time optimisation of the firmware images" ${TOF_LTO_DEFAULT})
  set(lto_flags "")
  if(TOF_LTO)
    # Functions called once are not inlined across files at the link: merged into their one
    # caller they made the image larger and the deepest frames deeper (m4 60,972 -> 60,720 B,
    # worst stack 2,364 -> 2,168 B; m0plus 65,192 -> 64,276 B, 2,712 -> 2,332 B).
    set(lto_flags -flto -fno-inline-functions-called-once)
  endif()
  list(REMOVE_DUPLICATES TOF_CORES)
  foreach(core IN LISTS TOF_CORES)
    set(core_lto "")
    if(TOF_LTO)
      set(core_lto ${lto_flags} ${TOF_CORE_LTO_FLAGS_${core}})
    endif()
    set(codegen ${TOF_CORE_FLAGS_${core}} ${core_lto}
      -ffunction-sections -fdata-sections -fstack-usage -fcallgraph-info=su -fno-common ${TOF_OPT_FLAGS} -g3)
    add_library(tof_core_${core} INTERFACE)
    target_compile_options(tof_core_${core} INTERFACE ${codegen})
    if(TOF_LTO)
      target_link_options(tof_core_${core} INTERFACE ${codegen})
    else()
      target_link_options(tof_core_${core} INTERFACE ${TOF_CORE_FLAGS_${core}})
    endif()
  endforeach()
  set(TOF_TARGET_CORES ${TOF_CORES})
else()
  set(TOF_TARGET_CORES host)
  add_library(tof_core_host INTERFACE)
  if(TOF_SANITIZE)
    target_compile_options(tof_core_host INTERFACE
      -fsanitize=address,undefined -fno-sanitize-recover=all -fno-omit-frame-pointer)
    target_link_options(tof_core_host INTERFACE -fsanitize=address,undefined)
  endif()
endif()

# tof_component(NAME SOURCES ... [INCLUDES ...] [DEPS ...] [HOST_ONLY] [CORES ...])
# Declares a library once; it is built as NAME on the host and as NAME_<core>
# for each core of a cross build (DEPS resolve the same way). HOST_ONLY skips
# cross builds; CORES restricts the cores it is built for (pose: FPU cores only).
function(tof_component name)
  cmake_parse_arguments(ARG "HOST_ONLY" "" "SOURCES;INCLUDES;DEPS;CORES" ${ARGN})
  if(CMAKE_CROSSCOMPILING AND ARG_HOST_ONLY)
    return()
  endif()
  foreach(core IN LISTS TOF_TARGET_CORES)
    if(ARG_CORES AND CMAKE_CROSSCOMPILING AND NOT core IN_LIST ARG_CORES)
      continue()
    endif()
    tof_name(lib ${name} ${core})
    add_library(${lib} STATIC ${ARG_SOURCES})
    target_include_directories(${lib} PUBLIC ${ARG_INCLUDES})
    target_link_libraries(${lib} PUBLIC tof_core_${core} PRIVATE tof_warnings)
    foreach(dep IN LISTS ARG_DEPS)
      tof_name(dep_lib ${dep} ${core})
      target_link_libraries(${lib} PUBLIC ${dep_lib})
    endforeach()
  endforeach()
endfunction()

# tof_name(OUT NAME CORE): the library name of component NAME for CORE.
function(tof_name out name core)
  if(core STREQUAL "host")
    set(${out} ${name} PARENT_SCOPE)
  else()
    set(${out} ${name}_${core} PARENT_SCOPE)
  endif()
endfunction()

# tof_image(NAME CORE LINKER_SCRIPT DEPS ... SOURCES ... [NO_FLOAT] [FLIGHT])
# A firmware ELF with a map file, a .bin, a size report and the image checks:
# no heap function may be linked; with NO_FLOAT, no floating-point helper; with FLIGHT,
# the flight budget (64 KiB of flash, 16 KiB of RAM with the stack).
function(tof_image name)
  cmake_parse_arguments(ARG "NO_FLOAT;FLIGHT" "CORE;LINKER_SCRIPT" "SOURCES;DEPS" ${ARGN})
  add_executable(${name} ${ARG_SOURCES})
  set_target_properties(${name} PROPERTIES SUFFIX ".elf")
  target_link_libraries(${name} PRIVATE tof_core_${ARG_CORE} tof_warnings)
  foreach(dep IN LISTS ARG_DEPS)
    tof_name(dep_lib ${dep} ${ARG_CORE})
    target_link_libraries(${name} PRIVATE ${dep_lib})
  endforeach()
  target_link_options(${name} PRIVATE
    -T${ARG_LINKER_SCRIPT} -nostartfiles --specs=nano.specs
    -Wl,--gc-sections -Wl,-Map=$<TARGET_FILE_DIR:${name}>/${name}.map
    -Wl,--print-memory-usage -Wl,--no-warn-rwx-segments)
  set_target_properties(${name} PROPERTIES LINK_DEPENDS ${ARG_LINKER_SCRIPT})
  set(float_flag "")
  # Flight images keep a quarter of their stack free at the static worst case: a deeper
  # path fails the link, not a unit in the field.
  set(stack_margin 0)
  if(ARG_FLIGHT)
    set(stack_margin 25)
  endif()
  if(ARG_NO_FLOAT)
    set(float_flag -DNO_FLOAT=1)
  endif()
  if(ARG_FLIGHT)
    list(APPEND float_flag -DSIZE=${CMAKE_SIZE} -DFLIGHT_BUDGET=1)
  endif()
  # The stack the linker script reserves, for the worst-case stack check (read at configure
  # time: an edit of the script configures again).
  set_property(DIRECTORY APPEND PROPERTY CMAKE_CONFIGURE_DEPENDS ${ARG_LINKER_SCRIPT})
  file(READ ${ARG_LINKER_SCRIPT} ld_text)
  if(ld_text MATCHES "STACK_SIZE = ([0-9]+)K;")
    math(EXPR stack_limit "${CMAKE_MATCH_1} * 1024")
  elseif(ld_text MATCHES "STACK_SIZE = ([0-9]+);")
    set(stack_limit ${CMAKE_MATCH_1})
  else()
    message(FATAL_ERROR "${ARG_LINKER_SCRIPT}: no 'STACK_SIZE = <n>K;' or '<bytes>;' line")
  endif()
  # The call graphs of what is linked: each object's own, or with link-time optimisation the
  # link's partitions (written into a folder of the image's own, emptied before each link).
  set(graph_args --root ${CMAKE_BINARY_DIR} --match _${ARG_CORE}.dir --match /${name}.dir/)
  if(TOF_LTO)
    set(lto_dir ${CMAKE_CURRENT_BINARY_DIR}/${name}.lto)
    target_link_options(${name} PRIVATE -dumpdir ${lto_dir}/)
    add_custom_command(TARGET ${name} PRE_LINK
      COMMAND ${CMAKE_COMMAND} -E remove_directory ${lto_dir}
      COMMAND ${CMAKE_COMMAND} -E make_directory ${lto_dir} VERBATIM)
    set(graph_args --root ${lto_dir} --match ltrans)
  endif()
  add_custom_command(TARGET ${name} POST_BUILD
    COMMAND ${CMAKE_COMMAND} -DNM=${CMAKE_NM} -DELF=$<TARGET_FILE:${name}> ${float_flag}
            -P ${PROJECT_SOURCE_DIR}/cmake/check_image.cmake
    COMMAND /usr/bin/python3 ${PROJECT_SOURCE_DIR}/tools/stack_check.py
            ${graph_args}
            --map $<TARGET_FILE_DIR:${name}>/${name}.map --elf $<TARGET_FILE:${name}>
            --limit ${stack_limit} --min-free-percent ${stack_margin} --name ${name} --narrow
            --json $<TARGET_FILE_DIR:${name}>/${name}.stack.json
    COMMAND ${CMAKE_OBJCOPY} -O binary $<TARGET_FILE:${name}> $<TARGET_FILE_DIR:${name}>/${name}.bin
    VERBATIM)
  set_property(GLOBAL APPEND PROPERTY TOF_IMAGES ${name})
endfunction()
