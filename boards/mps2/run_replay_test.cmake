# Target test: run the replay image under QEMU on TRACE and compare its estimate
# CSV byte for byte with GOLDEN (what host_sim writes for the same trace).
# cmake -DQEMU= -DBOARD= -DIMAGE= -DTRACE= -DOUT= -DGOLDEN= -P run_replay_test.cmake
# With EXPECT_FAIL (a regex), the replay must fail and say so instead; with
# STRIP_DISTANCE_MODE, TRACE is replayed without its '# distance_mode=' line.
file(REMOVE ${OUT})
if(STRIP_DISTANCE_MODE)
  file(READ ${TRACE} text)
  string(REGEX REPLACE "\n# distance_mode=[a-z]*\n" "\n" text "${text}")
  set(TRACE ${OUT}.trace.csv)
  file(WRITE ${TRACE} "${text}")
endif()
execute_process(
  COMMAND ${QEMU} -M ${BOARD} -nographic -monitor none -serial none
          -semihosting-config enable=on,target=native -kernel ${IMAGE}
          -append "${TRACE} ${OUT}"
  RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err TIMEOUT 540)
message("${out}")
if(DEFINED EXPECT_FAIL)
  if(rc EQUAL 0 OR NOT out MATCHES "${EXPECT_FAIL}")
    message(FATAL_ERROR "QEMU ${BOARD}: expected a failure matching '${EXPECT_FAIL}', got "
                        "'${rc}': ${out}${err}")
  endif()
  message(STATUS "QEMU ${BOARD}: refused as expected")
  return()
endif()
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "QEMU ${BOARD} replay exited with '${rc}': ${err}")
endif()
if(NOT out MATCHES "tof-attitude [0-9.]+\n${BOARD}\n")
  message(FATAL_ERROR "QEMU ${BOARD}: no boot banner naming the board")
endif()
execute_process(COMMAND ${CMAKE_COMMAND} -E compare_files ${OUT} ${GOLDEN} RESULT_VARIABLE diff)
if(NOT diff EQUAL 0)
  message(FATAL_ERROR "QEMU ${BOARD} estimates ${OUT} differ from host_sim's ${GOLDEN}")
endif()
file(STRINGS ${OUT} lines)
list(LENGTH lines n)
message(STATUS "QEMU ${BOARD}: ${n} lines identical to host_sim's")
