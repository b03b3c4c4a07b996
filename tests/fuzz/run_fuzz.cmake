# Run one libFuzzer target for a fixed time over its committed seed corpus
# (ctest label fuzz). New inputs go to a corpus in the build tree, never into
# the source tree; a crash leaves its input in WORK as crash-* (or leak-*,
# timeout-*, oom-*), and the test fails printing libFuzzer's report.
#   cmake -DFUZZER=<exe> -DSEEDS=<dir> -DWORK=<dir> -DSECONDS=15 [-DMAX_LEN=n]
#         -P run_fuzz.cmake
foreach(var FUZZER SEEDS WORK SECONDS)
  if(NOT DEFINED ${var})
    message(FATAL_ERROR "run_fuzz.cmake: -D${var}=... is required")
  endif()
endforeach()
if(NOT EXISTS ${SEEDS})
  message(FATAL_ERROR "run_fuzz.cmake: seed corpus ${SEEDS} does not exist")
endif()
set(extra "")
if(DEFINED MAX_LEN)
  list(APPEND extra -max_len=${MAX_LEN})
endif()
file(MAKE_DIRECTORY ${WORK}/corpus)
execute_process(
  COMMAND ${FUZZER} -max_total_time=${SECONDS} -timeout=10 -rss_limit_mb=2048
          -print_final_stats=1 -seed=1 ${extra} -artifact_prefix=${WORK}/
          ${WORK}/corpus ${SEEDS}
  RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
string(REGEX MATCH "stat::number_of_executed_units: *[0-9]+" runs "${err}")
string(REGEX MATCH "stat::average_exec_per_sec: *[0-9]+" speed "${err}")
string(REGEX MATCHALL "cov: [0-9]+ ft: [0-9]+" cov "${err}")
list(POP_BACK cov last_cov)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "fuzzer failed (exit ${rc}); input saved under ${WORK}\n${err}")
endif()
if(NOT runs)
  message(FATAL_ERROR "fuzzer printed no statistics; did it run?\n${err}")
endif()
message(STATUS "fuzz ok: ${runs}; ${speed}; last ${last_cov}")
