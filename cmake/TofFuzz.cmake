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
#     [ARGS <libFuzzer flag>...]   the campaign's flags (-max_len=N, -dict=FILE)
#     CORPUS <seed dir>...)        committed seeds, read only
#
# Builds OUTPUT_DIR/<name> (custom target <name>, in ALL, also a dependency of
# the target tof_fuzzers) and registers two ways to run it:
#
# - The ctest (label fuzz) executes every committed seed once under ASan/UBSan
#   and the harness's own invariants. Its verdict is a function of the commit
#   alone, the same on any machine. A mutation run is not: even with -seed=1,
#   -reload=0, one worker and a count bound, libFuzzer's comparison tables take
#   operand values, pointers among them, so address-space randomisation
#   changes the schedule (measured: fuzz_vl53, 20,000 runs, three runs, two
#   different coverages; identical with randomisation off, which a container's
#   seccomp profile commonly forbids).
# - Mutation campaigns run by a separate command, tools/fuzz_campaign.sh (or the
#   target fuzz_campaign), over every target listed in
#   ${CMAKE_BINARY_DIR}/fuzz_targets.txt, which this function writes. A crash
#   a campaign finds is fixed and its input committed to the target's first
#   CORPUS dir, where every later ctest replays it.

# --- runner (script mode) ----------------------------------------------------

# cmake -DFUZZ_EXE=<exe> "-DFUZZ_SEEDS=<dir;...>" -P TofFuzz.cmake
function(tof_fuzz_run)
  foreach(var FUZZ_EXE FUZZ_SEEDS)
    if(NOT DEFINED ${var})
      message(FATAL_ERROR "TofFuzz.cmake: -D${var}=... is required")
    endif()
  endforeach()
  if(NOT EXISTS "${FUZZ_EXE}")
    message(FATAL_ERROR "TofFuzz.cmake: fuzzer ${FUZZ_EXE} is not built")
  endif()
  set(inputs "")
  foreach(dir IN LISTS FUZZ_SEEDS)
    if(NOT IS_DIRECTORY "${dir}")
      message(FATAL_ERROR "TofFuzz.cmake: seed corpus ${dir} does not exist")
    endif()
    file(GLOB found LIST_DIRECTORIES false "${dir}/*")
    list(APPEND inputs ${found})
  endforeach()
  list(SORT inputs)
  list(LENGTH inputs count)
  if(count EQUAL 0)
    message(FATAL_ERROR "TofFuzz.cmake: no seeds in ${FUZZ_SEEDS}")
  endif()
  # Inputs named one by one: libFuzzer executes each once, whole (no -max_len
  # truncation), and stops.
  execute_process(
    COMMAND ${FUZZ_EXE} -timeout=10 -rss_limit_mb=2048 ${inputs}
    RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  string(REGEX MATCHALL "\nExecuted [^\n]*" executed "\n${err}")
  list(LENGTH executed ran)
  if(NOT rc EQUAL 0)
    list(GET FUZZ_SEEDS 0 first_seeds)
    message(FATAL_ERROR "a committed seed fails (exit ${rc}): fix the code; the input is "
                        "already a regression seed under ${first_seeds}\n${err}")
  endif()
  if(NOT ran EQUAL count)
    message(FATAL_ERROR "fuzzer executed ${ran} of ${count} seeds\n${err}")
  endif()
  message(STATUS "fuzz ok: ${count} committed seeds executed, none failed")
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
  # The campaign's list starts empty at each configure; tof_fuzz_target appends.
  file(WRITE ${CMAKE_BINARY_DIR}/fuzz_targets.txt "")
  set(TOF_FUZZ_CAMPAIGN_SECONDS 600 CACHE STRING "Seconds each target runs in fuzz_campaign")
  add_custom_target(fuzz_campaign
    COMMAND sh ${PROJECT_SOURCE_DIR}/tools/fuzz_campaign.sh ${CMAKE_BINARY_DIR}
            ${TOF_FUZZ_CAMPAIGN_SECONDS}
    DEPENDS tof_fuzzers USES_TERMINAL
    COMMENT "libFuzzer campaign: every target for ${TOF_FUZZ_CAMPAIGN_SECONDS} s")
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
  cmake_parse_arguments(ARG "" "OUTPUT_DIR;TEST"
    "SOURCES;INCLUDES;DEFINITIONS;LIBS;COMPILE_OPTIONS;ARGS;CORPUS" ${ARGN})
  if(ARG_UNPARSED_ARGUMENTS)
    message(FATAL_ERROR "tof_fuzz_target(${name}): unknown arguments ${ARG_UNPARSED_ARGUMENTS}")
  endif()
  foreach(required SOURCES CORPUS)
    if(NOT ARG_${required})
      message(FATAL_ERROR "tof_fuzz_target(${name}): ${required} is required")
    endif()
  endforeach()
  if(ARG_ARGS MATCHES "(^|;)-(runs|max_total_time|jobs|workers|fork)=")
    message(FATAL_ERROR "tof_fuzz_target(${name}): ARGS are the campaign's input flags; "
                        "its length is fuzz_campaign.sh's: ${ARG_ARGS}")
  endif()
  if(NOT ARG_TEST)
    set(ARG_TEST fuzz.${name})
  endif()
  if(NOT ARG_OUTPUT_DIR)
    set(ARG_OUTPUT_DIR ${CMAKE_CURRENT_BINARY_DIR}/fuzz)
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
    COMMAND ${CMAKE_COMMAND} -DFUZZ_EXE=${exe} "-DFUZZ_SEEDS=${seeds}"
            -P ${CMAKE_CURRENT_FUNCTION_LIST_FILE})
  set_tests_properties(${ARG_TEST} PROPERTIES LABELS fuzz TIMEOUT 300)

  # One line per target for the campaign: name|binary|seed dirs|flags.
  list(JOIN seeds " " seed_words)
  list(JOIN ARG_ARGS " " arg_words)
  file(APPEND ${CMAKE_BINARY_DIR}/fuzz_targets.txt "${name}|${exe}|${seed_words}|${arg_words}\n")
endfunction()
