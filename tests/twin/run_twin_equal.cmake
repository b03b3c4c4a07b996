# The demo trace through the twin (strict mode) gives the EST.csv rows host_sim replay
# gives with the same options: every column (t_ms, angles, distance, status, the three sd and
# why, docs/reference/tools.md).
# Empty fields (no value, an empty why) are list elements too: without CMP0007 NEW, list()
# drops them and the columns after one shift.
cmake_policy(SET CMP0007 NEW)
if(NOT EXISTS "${ELF}")
  message(FATAL_ERROR "twin test: ${ELF} missing: build the m4 preset first "
                      "(cmake --preset m4 && cmake --build --preset m4)")
endif()
if(NOT EXISTS "${HOST_SIM}")
  message(FATAL_ERROR "twin test: ${HOST_SIM} missing: build the host-release preset first "
                      "(cmake --preset host-release && cmake --build --preset host-release)")
endif()
file(MAKE_DIRECTORY ${OUT})
# TRACE_META (optional): metadata lines put after the trace's first line in place of its own
# calibration keys; the copy is written beside the outputs. HOST_ARGS: host_sim's own extra
# options (the twin's are TWIN_ARGS).
if(DEFINED TRACE_META)
  # (text, not a CMake list: a metadata value may hold ';')
  file(READ ${TRACE} text)
  string(REGEX REPLACE "# (offset_mm|offset_sd_mm|gain|gain_sd|calibration)=[^\n]*\n" "" text
                       "${text}")
  string(REPLACE "|" "\n" meta "${TRACE_META}")
  string(FIND "${text}" "\n" nl)
  math(EXPR nl "${nl} + 1")
  string(SUBSTRING "${text}" 0 ${nl} first)
  string(SUBSTRING "${text}" ${nl} -1 rest)
  set(text "${first}${meta}\n${rest}")
  file(WRITE ${OUT}/trace.csv "${text}")
  set(TRACE ${OUT}/trace.csv)
endif()
# GEOMETRY (optional): "ARM_MM;PERIOD_MS;ROWS": the trace's first ROWS rows as a head with
# that arm recorded at that period (t_ms re-spaced, arm_mm and period_ms replaced): the flight
# image boots into them from its saved settings, host_sim configures them directly.
if(DEFINED GEOMETRY)
  list(GET GEOMETRY 0 arm)
  list(GET GEOMETRY 1 period)
  list(GET GEOMETRY 2 rows)
  find_package(Python3 REQUIRED COMPONENTS Interpreter)
  execute_process(COMMAND ${Python3_EXECUTABLE} -c "
import sys
src, dst, arm, period, rows = sys.argv[1], sys.argv[2], sys.argv[3], int(sys.argv[4]), int(sys.argv[5])
out, n, header = [], 0, False
for line in open(src):
    if line.startswith('# arm_mm='):
        line = '# arm_mm=%s\\n' % arm
    elif line.startswith('# period_ms='):
        line = '# period_ms=%d\\n' % period
    elif line.startswith('t_ms,'):
        header = True
    elif header and not line.startswith('#'):
        if n == rows:
            break
        f = line.split(',')
        f[0] = str(n * period)
        line = ','.join(f)
        n += 1
    out.append(line)
open(dst, 'w').write(''.join(out))
" ${TRACE} ${OUT}/geometry.csv ${arm} ${period} ${rows} RESULT_VARIABLE rc)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "could not write the re-timed trace (${rc})")
  endif()
  set(TRACE ${OUT}/geometry.csv)
endif()
# CMDS: "--command;ROW:TEXT;..." given to both (docs/reference/tools.md): a host's commands at a row.
execute_process(COMMAND ${HOST_SIM} replay ${TRACE} --estimator ${EST} ${CMDS}
                        --out ${OUT}/host_sim.csv ${HOST_ARGS}
                RESULT_VARIABLE rc OUTPUT_QUIET)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "host_sim replay failed (${rc})")
endif()
execute_process(COMMAND ${TWIN} ${ELF} ${TRACE} --estimator ${EST} --strict ${TWIN_ARGS} ${CMDS}
                        --out ${OUT}/twin.csv --report ${OUT}/report.json
                RESULT_VARIABLE rc ERROR_VARIABLE err)
message("${err}")
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "tof_twin failed (${rc})")
endif()
function(columns path out)
  file(STRINGS ${path} lines)
  list(GET lines 0 header)
  string(REPLACE "," ";" names "${header}")
  set(want t_ms alpha_deg beta_deg distance_mm status alpha_sd_deg beta_sd_deg distance_sd_mm why)
  set(idx "")
  foreach(w IN LISTS want)
    list(FIND names ${w} i)
    if(i LESS 0)
      message(FATAL_ERROR "${path}: no column ${w}")
    endif()
    list(APPEND idx ${i})
  endforeach()
  set(rows "")
  list(REMOVE_AT lines 0)
  foreach(l IN LISTS lines)
    string(REPLACE "," ";" f "${l},")
    set(r "")
    foreach(i IN LISTS idx)
      list(GET f ${i} v)
      string(APPEND r "${v},")
    endforeach()
    list(APPEND rows "${r}")
  endforeach()
  set(${out} "${rows}" PARENT_SCOPE)
endfunction()
columns(${OUT}/host_sim.csv a)
columns(${OUT}/twin.csv b)
list(LENGTH a na)
list(LENGTH b nb)
if(na EQUAL 0 OR NOT na EQUAL nb)
  message(FATAL_ERROR "row counts differ: host_sim ${na}, twin ${nb}")
endif()
math(EXPR last "${na} - 1")
foreach(i RANGE ${last})
  list(GET a ${i} ra)
  list(GET b ${i} rb)
  if(NOT ra STREQUAL rb)
    message(FATAL_ERROR "row ${i} differs: host_sim '${ra}', twin '${rb}'")
  endif()
endforeach()
if(TWIN_ARGS MATCHES "spurious-berr")
  file(READ ${OUT}/report.json rep)
  string(REGEX MATCH "\"spurious_berr\": ([0-9]+)" m "${rep}")
  if(NOT CMAKE_MATCH_1 GREATER 100)
    message(FATAL_ERROR "only ${CMAKE_MATCH_1} spurious BERR injected")
  endif()
  string(REGEX MATCH "\"bus_recoveries\": ([0-9]+)" m "${rep}")
  if(NOT CMAKE_MATCH_1 EQUAL 0)
    message(FATAL_ERROR "${CMAKE_MATCH_1} bus recoveries after spurious BERR")
  endif()
endif()
if(DEFINED EXPECT_CAL)
  # the calibration the flight firmware's boot found (status frame), and the files equal
  # byte for byte (the twin's rows are host_sim's with the same calibration)
  file(READ ${OUT}/report.json rep)
  string(REGEX MATCH "\"calibration_state\": ([0-9]+)" m "${rep}")
  if(NOT CMAKE_MATCH_1 STREQUAL "${EXPECT_CAL}")
    message(FATAL_ERROR "the firmware's boot found calibration state '${CMAKE_MATCH_1}', "
                        "expected ${EXPECT_CAL}")
  endif()
  file(READ ${OUT}/host_sim.csv fa)
  file(READ ${OUT}/twin.csv fb)
  if(NOT fa STREQUAL fb)
    message(FATAL_ERROR "EST.csv files differ byte for byte")
  endif()
endif()
if(CMDS)
  # Every command sent was acknowledged, and the loop kept its budget while they ran.
  file(READ ${OUT}/report.json rep)
  string(REGEX MATCH "\"commands_sent\": ([0-9]+)" m "${rep}")
  set(sent ${CMAKE_MATCH_1})
  string(REGEX MATCH "\"commands_acked\": ([0-9]+)" m "${rep}")
  if(NOT sent GREATER 0 OR NOT CMAKE_MATCH_1 EQUAL sent)
    message(FATAL_ERROR "commands: ${sent} sent, ${CMAKE_MATCH_1} acknowledged")
  endif()
  string(REGEX MATCH "\"loop_max_us\": ([0-9]+)" m "${rep}")
  if(CMAKE_MATCH_1 GREATER 10000)
    message(FATAL_ERROR "worst loop ${CMAKE_MATCH_1} us, over half the 20 ms period")
  endif()
  foreach(key loop_overruns tx_dropped uart_overruns rows_missing watchdog_resets)
    string(REGEX MATCH "\"${key}\": ([0-9]+)" m "${rep}")
    if(NOT CMAKE_MATCH_1 EQUAL 0)
      message(FATAL_ERROR "${key} = ${CMAKE_MATCH_1}, expected 0")
    endif()
  endforeach()
endif()
message(STATUS "twin == host_sim: ${na} rows (${EST} ${TWIN_ARGS} ${CMDS})")
