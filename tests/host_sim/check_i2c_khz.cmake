# host_sim replay --i2c-khz (docs/reference/tools.md): -DHOST_SIM -DTRACE (a 20 ms trace) -DOUT.
# 1. At 100 kHz a 20 ms period is refused: exit status 1 and a message naming the period and the
#    bus clock. 2. The same rows at a 40 ms period replay at 100 kHz with every sample complete
#    and estimates byte for byte those at 400 kHz (the bus clock changes the timing, never a
#    value). 3. Anything but 100 or 400 is a usage error.
file(MAKE_DIRECTORY ${OUT})
execute_process(COMMAND ${HOST_SIM} replay ${TRACE} --i2c-khz 100 --quiet
                RESULT_VARIABLE rc ERROR_VARIABLE err)
if(NOT rc EQUAL 1 OR NOT err MATCHES "period_ms 20 at --i2c-khz 100.*refuses it.*31 ms")
  message(FATAL_ERROR "20 ms at 100 kHz: exit ${rc}, expected 1 and the refusal:\n${err}")
endif()
# The trace at 40 ms: its metadata's period and every row's t_ms doubled.
file(STRINGS ${TRACE} lines)
set(text "")
foreach(line IN LISTS lines)
  if(line MATCHES "^# period_ms=")
    string(APPEND text "# period_ms=40\n")
  elseif(line MATCHES "^([0-9]+)(,.*)$")
    math(EXPR t "${CMAKE_MATCH_1} * 2")
    string(APPEND text "${t}${CMAKE_MATCH_2}\n")
  else()
    string(APPEND text "${line}\n")
  endif()
endforeach()
file(WRITE ${OUT}/at40.csv "${text}")
foreach(khz 100 400)
  execute_process(COMMAND ${HOST_SIM} replay ${OUT}/at40.csv --i2c-khz ${khz} --quiet
                          --out ${OUT}/at40_${khz}.est.csv --report ${OUT}/at40_${khz}.json
                  RESULT_VARIABLE rc ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "40 ms at ${khz} kHz: exit ${rc}:\n${err}")
  endif()
  file(READ ${OUT}/at40_${khz}.json rep)
  if(NOT rep MATCHES "\"incomplete_samples\": 0," OR NOT rep MATCHES "\"overruns\": 0,")
    message(FATAL_ERROR "40 ms at ${khz} kHz: samples incomplete or loop overruns: ${rep}")
  endif()
endforeach()
execute_process(COMMAND ${CMAKE_COMMAND} -E compare_files ${OUT}/at40_100.est.csv
                        ${OUT}/at40_400.est.csv RESULT_VARIABLE same)
if(NOT same EQUAL 0)
  message(FATAL_ERROR "40 ms: the estimates at 100 kHz differ from those at 400 kHz")
endif()
execute_process(COMMAND ${HOST_SIM} replay ${OUT}/at40.csv --i2c-khz 250 --quiet
                RESULT_VARIABLE rc ERROR_VARIABLE err)
if(NOT rc EQUAL 2 OR NOT err MATCHES "--i2c-khz: expected 100 or 400")
  message(FATAL_ERROR "--i2c-khz 250: exit ${rc}, expected 2 and a usage error:\n${err}")
endif()
message(STATUS "100 kHz: 20 ms refused; 40 ms complete, estimates equal to 400 kHz")
