# A fault run in the twin (NACK bursts, sensor resets, a device holding SDA low, spurious
# BERR of errata ES0250): it must finish (no hang, no lockup), recover the bus, and have no
# ok estimate more than 5x its window's Cramer-Rao bound from the truth.
file(MAKE_DIRECTORY ${OUT})
# Rates low enough that some windows stay ok (so "no unflagged wrong estimate" is tested
# on ok rows), high enough for NACKs, resets and stuck buses in 100 s.
execute_process(COMMAND ${TWIN} ${ELF} ${TRACE} --strict
                        --faults nack=0.001,reset=0.00005,stuck=0.00005
                        --seed 7 --out ${OUT}/twin.csv --report ${OUT}/report.json
                RESULT_VARIABLE rc ERROR_VARIABLE err)
message("${err}")
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "tof_twin fault run failed (${rc})")
endif()
file(READ ${OUT}/report.json rep)
foreach(key finished unflagged_wrong rows_written bus_recoveries hardfaults ok_rows
            watchdog_resets)
  string(REGEX MATCH "\"${key}\": ([a-z0-9]+)" m "${rep}")
  set(${key} ${CMAKE_MATCH_1})
endforeach()
if(NOT finished STREQUAL "true")
  message(FATAL_ERROR "fault run did not finish")
endif()
if(NOT unflagged_wrong EQUAL 0)
  message(FATAL_ERROR "${unflagged_wrong} unflagged wrong estimates")
endif()
if(rows_written LESS 40)
  message(FATAL_ERROR "only ${rows_written} estimate rows in the fault run")
endif()
if(bus_recoveries LESS 1)
  message(FATAL_ERROR "no bus recovery: the stuck-SDA fault was not exercised")
endif()
if(ok_rows LESS 5)
  message(FATAL_ERROR "only ${ok_rows} ok rows: the unflagged-wrong check tests nothing")
endif()
if(NOT watchdog_resets EQUAL 0)
  message(FATAL_ERROR "${watchdog_resets} watchdog resets in the fault run")
endif()
if(NOT hardfaults EQUAL 0)
  message(FATAL_ERROR "${hardfaults} HardFaults in the fault run")
endif()
message(STATUS "fault run: ${rows_written} rows (${ok_rows} ok), ${bus_recoveries} bus recoveries, 0 unflagged wrong")
