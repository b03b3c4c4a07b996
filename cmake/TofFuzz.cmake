# libFuzzer targets and their ctests (label fuzz), one mechanism for every
# folder of tests/. Included by tests/CMakeLists.txt.
#
# libFuzzer needs clang's -fsanitize=fuzzer runtime (Debian: clang +
# libclang-rt-14-dev, installed by tools/setup.sh), so every target is compiled
# by clang directly through a custom command, whatever the project's compiler
# is (the host presets use gcc). Whether this clang can link a fuzzer is probed
# once and cached; without one, no fuzz test is registered and the configure
# prints one warning naming every test left out.
#
# tof_fuzz_target(<name>
#     SOURCES <file>...            harness + the code under test (no libraries: all
#                                  of it is built with the fuzzer's sanitizers)
#     [INCLUDES <dir>...]          -I directories
#     [DEFINITIONS <NAME[=value]>...]
#     [LIBS <flag>...]             link flags, e.g. -lm
#     [COMPILE_OPTIONS <flag>...]  after the standard flags (exemptions, with a reason)
#     [OUTPUT_DIR <dir>]           default ${CMAKE_CURRENT_BINARY_DIR}/fuzz
#     [TEST <ctest name>]          default fuzz.<name>
#     ARGS <libFuzzer flag>...     must bound the run: -runs=N or -max_total_time=S
#     CORPUS <seed dir>...         committed seeds, read only
#     [WORK <dir>])                default ${CMAKE_CURRENT_BINARY_DIR}/<name>_work
#
# Builds OUTPUT_DIR/<name> (custom target <name>, in ALL, also a dependency of
# the target tof_fuzzers). The test runs the binary with ARGS over WORK/corpus
# (new inputs land there, never in the source tree) and the CORPUS dirs; a
# crash, leak or timeout leaves its input as WORK/crash-* (leak-*, timeout-*,
# oom-*) and fails the test with libFuzzer's report. ctest TIMEOUT is 300 s.
#
# This file is also the test runner (cmake -P cmake/TofFuzz.cmake, see
# tof_fuzz_run below).

# --- runner (script mode) ----------------------------------------------------

# cmake -DFUZZ_EXE=<exe> -DFUZZ_WORK=<dir> "-DFUZZ_ARGS=<flag;...>"
#       "-DFUZZ_SEEDS=<dir;...>" -P TofFuzz.cmake
function(tof_fuzz_run)
  foreach(var FUZZ_EXE FUZZ_WORK FUZZ_ARGS FUZZ_SEEDS)
    if(NOT DEFINED ${var})
      message(FATAL_ERROR "TofFuzz.cmake: -D${var}=... is required")
    endif()
  endforeach()
  if(NOT EXISTS "${FUZZ_EXE}")
    message(FATAL_ERROR "TofFuzz.cmake: fuzzer ${FUZZ_EXE} is not built")
  endif()
  foreach(dir IN LISTS FUZZ_SEEDS)
    if(NOT IS_DIRECTORY "${dir}")
      message(FATAL_ERROR "TofFuzz.cmake: seed corpus ${dir} does not exist")
    endif()
  endforeach()
  file(MAKE_DIRECTORY ${FUZZ_WORK}/corpus)
  execute_process(
    COMMAND ${FUZZ_EXE} ${FUZZ_ARGS} -print_final_stats=1 -artifact_prefix=${FUZZ_WORK}/
            ${FUZZ_WORK}/corpus ${FUZZ_SEEDS}
    RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  string(REGEX MATCH "stat::number_of_executed_units: *[0-9]+" runs "${err}")
  string(REGEX MATCH "stat::average_exec_per_sec: *[0-9]+" speed "${err}")
  string(REGEX MATCHALL "cov: [0-9]+ ft: [0-9]+" cov "${err}")
  set(last_cov "")
  if(cov)
    list(POP_BACK cov last_cov)
  endif()
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "fuzzer failed (exit ${rc}); input saved under ${FUZZ_WORK}\n${err}")
  endif()
  if(NOT runs)
    message(FATAL_ERROR "fuzzer printed no statistics; did it run?\n${err}")
  endif()
  message(STATUS "fuzz ok: ${runs}; ${speed}; last ${last_cov}")
endfunction()

if(CMAKE_SCRIPT_MODE_FILE STREQUAL CMAKE_CURRENT_LIST_FILE)
  tof_fuzz_run()
  return()
endif()

# --- configure: find and probe clang once ------------------------------------

# A clang project compiler is the natural choice; otherwise clang from PATH.
if(CMAKE_C_COMPILER_ID STREQUAL "Clang" AND NOT TOF_FUZZ_CLANG)
  set(TOF_FUZZ_CLANG ${CMAKE_C_COMPILER} CACHE FILEPATH "clang that builds the libFuzzer targets")
endif()
find_program(TOF_FUZZ_CLANG NAMES clang clang-14 DOC "clang that builds the libFuzzer targets")

# Probe again only when the clang changes (the result is cached per path).
if(TOF_FUZZ_CLANG AND NOT TOF_FUZZ_PROBED_CLANG STREQUAL TOF_FUZZ_CLANG)
  set(probe_dir ${CMAKE_BINARY_DIR}/CMakeFiles/tof_fuzz_probe)
  file(WRITE ${probe_dir}/probe.c
    "#include <stddef.h>\n#include <stdint.h>\n"
    "int LLVMFuzzerTestOneInput(const uint8_t *d, size_t n);\n"
    "int LLVMFuzzerTestOneInput(const uint8_t *d, size_t n) { (void)d; (void)n; return 0; }\n")
  execute_process(COMMAND ${TOF_FUZZ_CLANG} -fsanitize=fuzzer,address,undefined
                          ${probe_dir}/probe.c -o ${probe_dir}/probe
                  RESULT_VARIABLE probe_rc OUTPUT_QUIET ERROR_VARIABLE probe_err)
  string(STRIP "${probe_err}" probe_err)
  if(probe_err STREQUAL "")
    set(probe_err "exit ${probe_rc}")
  endif()
  if(probe_rc EQUAL 0)
    set(TOF_FUZZ_CLANG_OK ON CACHE INTERNAL "TOF_FUZZ_CLANG links -fsanitize=fuzzer")
  else()
    set(TOF_FUZZ_CLANG_OK OFF CACHE INTERNAL "TOF_FUZZ_CLANG links -fsanitize=fuzzer")
  endif()
  set(TOF_FUZZ_PROBE_ERROR "${probe_err}" CACHE INTERNAL "why the libFuzzer probe failed")
  set(TOF_FUZZ_PROBED_CLANG ${TOF_FUZZ_CLANG} CACHE INTERNAL "clang the libFuzzer probe ran")
endif()
if(TOF_FUZZ_CLANG AND TOF_FUZZ_CLANG_OK)
  set(TOF_FUZZ_ENABLED TRUE)
else()
  set(TOF_FUZZ_ENABLED FALSE)
endif()

# ASan + UBSan with every UB fatal, and the project's warnings (cmake/TofBuild.cmake)
# as far as clang shares them.
set(TOF_FUZZ_FLAGS -std=c11 -g -O1 -fno-omit-frame-pointer
    -fsanitize=fuzzer,address,undefined -fno-sanitize-recover=all
    -Wall -Wextra -Werror -Wconversion -Wsign-conversion -Wshadow -Wundef -Wcast-align
    -Wpointer-arith -Wformat=2 -Wnull-dereference -Wdouble-promotion -Wstrict-prototypes
    -Wmissing-prototypes -Wold-style-definition)

if(TOF_FUZZ_ENABLED AND NOT TARGET tof_fuzzers)
  add_custom_target(tof_fuzzers ALL)
endif()

# One warning per configure listing every fuzz test left out (deferred to the
# end of the top-level directory, after every folder has declared its targets).
function(tof_fuzz_report_missing)
  get_property(missing GLOBAL PROPERTY TOF_FUZZ_MISSING)
  list(JOIN missing ", " missing)
  if(TOF_FUZZ_CLANG)
    set(why "clang: '${TOF_FUZZ_CLANG}'; ${TOF_FUZZ_PROBE_ERROR}")
  else()
    set(why "no clang or clang-14 on PATH; TOF_FUZZ_CLANG names one")
  endif()
  message(WARNING
    "\n*** fuzz tests NOT registered (${missing}): no clang able to link "
    "-fsanitize=fuzzer,address,undefined (${why}). "
    "Install clang and libclang-rt-14-dev (tools/setup.sh). ***\n")
endfunction()

function(tof_fuzz_target name)
  cmake_parse_arguments(ARG "" "OUTPUT_DIR;TEST;WORK"
    "SOURCES;INCLUDES;DEFINITIONS;LIBS;COMPILE_OPTIONS;ARGS;CORPUS" ${ARGN})
  if(ARG_UNPARSED_ARGUMENTS)
    message(FATAL_ERROR "tof_fuzz_target(${name}): unknown arguments ${ARG_UNPARSED_ARGUMENTS}")
  endif()
  foreach(required SOURCES ARGS CORPUS)
    if(NOT ARG_${required})
      message(FATAL_ERROR "tof_fuzz_target(${name}): ${required} is required")
    endif()
  endforeach()
  # Without a bound libFuzzer runs until ctest kills it.
  if(NOT ARG_ARGS MATCHES "(^|;)-(runs|max_total_time)=[0-9]+(;|$)")
    message(FATAL_ERROR "tof_fuzz_target(${name}): ARGS must bound the run "
                        "(-runs=N or -max_total_time=S): ${ARG_ARGS}")
  endif()
  if(NOT ARG_TEST)
    set(ARG_TEST fuzz.${name})
  endif()
  if(NOT ARG_OUTPUT_DIR)
    set(ARG_OUTPUT_DIR ${CMAKE_CURRENT_BINARY_DIR}/fuzz)
  endif()
  if(NOT ARG_WORK)
    set(ARG_WORK ${CMAKE_CURRENT_BINARY_DIR}/${name}_work)
  endif()

  if(NOT TOF_FUZZ_ENABLED)
    set_property(GLOBAL APPEND PROPERTY TOF_FUZZ_MISSING ${ARG_TEST})
    get_property(deferred GLOBAL PROPERTY TOF_FUZZ_REPORT_DEFERRED)
    if(NOT deferred)
      set_property(GLOBAL PROPERTY TOF_FUZZ_REPORT_DEFERRED ON)
      cmake_language(DEFER DIRECTORY ${CMAKE_SOURCE_DIR} CALL tof_fuzz_report_missing)
    endif()
    return()
  endif()

  # Sources, their folders' private headers and every header under INCLUDES:
  # the binary is rebuilt when any of them changes.
  set(sources "")
  set(headers "")
  foreach(src IN LISTS ARG_SOURCES)
    get_filename_component(src ${src} ABSOLUTE BASE_DIR ${CMAKE_CURRENT_SOURCE_DIR})
    if(NOT EXISTS ${src})
      message(FATAL_ERROR "tof_fuzz_target(${name}): source ${src} does not exist")
    endif()
    list(APPEND sources ${src})
    get_filename_component(src_dir ${src} DIRECTORY)
    file(GLOB private_headers CONFIGURE_DEPENDS ${src_dir}/*.h)
    list(APPEND headers ${private_headers})
  endforeach()
  set(includes "")
  foreach(dir IN LISTS ARG_INCLUDES)
    get_filename_component(dir ${dir} ABSOLUTE BASE_DIR ${CMAKE_CURRENT_SOURCE_DIR})
    list(APPEND includes -I${dir})
    file(GLOB_RECURSE public_headers CONFIGURE_DEPENDS ${dir}/*.h)
    list(APPEND headers ${public_headers})
  endforeach()
  list(REMOVE_DUPLICATES headers)
  list(TRANSFORM ARG_DEFINITIONS PREPEND -D OUTPUT_VARIABLE definitions)

  # The binary sits in its own folder: a file named like its custom target in
  # the target's own binary dir would clash with the target under Ninja.
  set(exe ${ARG_OUTPUT_DIR}/${name})
  file(MAKE_DIRECTORY ${ARG_OUTPUT_DIR})
  add_custom_command(OUTPUT ${exe}
    COMMAND ${TOF_FUZZ_CLANG} ${TOF_FUZZ_FLAGS} ${ARG_COMPILE_OPTIONS} ${definitions}
            ${includes} ${sources} ${ARG_LIBS} -o ${exe}
    DEPENDS ${sources} ${headers}
    COMMENT "libFuzzer target ${name} (${TOF_FUZZ_CLANG})"
    VERBATIM)
  add_custom_target(${name} ALL DEPENDS ${exe})
  add_dependencies(tof_fuzzers ${name})

  set(seeds "")
  foreach(dir IN LISTS ARG_CORPUS)
    get_filename_component(dir ${dir} ABSOLUTE BASE_DIR ${CMAKE_CURRENT_SOURCE_DIR})
    list(APPEND seeds ${dir})
  endforeach()
  add_test(NAME ${ARG_TEST}
    COMMAND ${CMAKE_COMMAND} -DFUZZ_EXE=${exe} -DFUZZ_WORK=${ARG_WORK}
            "-DFUZZ_ARGS=${ARG_ARGS}" "-DFUZZ_SEEDS=${seeds}"
            -P ${CMAKE_CURRENT_FUNCTION_LIST_FILE})
  set_tests_properties(${ARG_TEST} PROPERTIES LABELS fuzz TIMEOUT 300)
endfunction()
