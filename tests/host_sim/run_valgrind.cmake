# Replay a trace through host_sim under valgrind memcheck: any invalid access,
# use of uninitialised memory, bad free or leak fails the test (exit 1 from
# --error-exitcode), and the replay itself must succeed and write its outputs.
#   cmake -DVALGRIND=<valgrind> -DHOST_SIM=<host_sim> -DTRACE=<csv> -DWORK=<dir>
#         -DESTIMATOR=<name> -DMODE=tumbling|sliding [-DFAULTS=<spec>] -P run_valgrind.cmake
foreach(var VALGRIND HOST_SIM TRACE WORK ESTIMATOR MODE)
  if(NOT DEFINED ${var})
    message(FATAL_ERROR "run_valgrind.cmake: -D${var}=... is required")
  endif()
endforeach()
file(REMOVE_RECURSE ${WORK})
file(MAKE_DIRECTORY ${WORK})
set(faults "")
if(FAULTS)
  set(faults --faults ${FAULTS} --seed 7)
endif()
execute_process(
  COMMAND ${VALGRIND} --tool=memcheck --error-exitcode=1 --leak-check=full
          --show-leak-kinds=all --errors-for-leak-kinds=definite,indirect,possible
          --track-origins=yes --log-file=${WORK}/memcheck.log
          ${HOST_SIM} replay ${TRACE} --estimator ${ESTIMATOR} --mode ${MODE} ${faults}
          --out ${WORK}/est.csv --report ${WORK}/report.json
  RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
file(READ ${WORK}/memcheck.log log)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "host_sim under valgrind exited ${rc}\n${err}\n--- memcheck ---\n${log}")
endif()
string(REGEX MATCH "ERROR SUMMARY: [0-9]+ errors" summary "${log}")
if(NOT summary STREQUAL "ERROR SUMMARY: 0 errors")
  message(FATAL_ERROR "memcheck: ${summary}\n${log}")
endif()
if(NOT log MATCHES "All heap blocks were freed -- no leaks are possible" AND
   NOT log MATCHES "definitely lost: 0 bytes in 0 blocks")
  message(FATAL_ERROR "memcheck did not report a clean heap\n${log}")
endif()
foreach(f est.csv report.json)
  if(NOT EXISTS ${WORK}/${f})
    message(FATAL_ERROR "host_sim wrote no ${f}")
  endif()
endforeach()
file(STRINGS ${WORK}/est.csv rows)
list(LENGTH rows n)
if(n LESS 2)
  message(FATAL_ERROR "est.csv has no estimate rows")
endif()
math(EXPR n "${n} - 1")
message(STATUS "memcheck clean: ${summary}; ${n} estimates written")
