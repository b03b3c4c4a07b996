# The flight image built for a 100 kHz bus (TOF_I2C_KHZ=100, the m4-i2c100 preset) in the twin,
# whose I2C peripheral model paces the wire by the TIMINGR the image programs: the demo's rows
# re-timed to the image's 40 ms default period give host_sim --i2c-khz 100's rows (through
# run_twin_equal.cmake), with no loop overrun, no watchdog reset or fault,
# and the worst loop within half the period.
# -DTWIN -DHOST_SIM -DELF -DTRACE -DOUT, as run_twin_equal.cmake.
if(NOT EXISTS "${ELF}")
  message(FATAL_ERROR "twin test: ${ELF} missing: build the m4-i2c100 preset first "
                      "(cmake --preset m4-i2c100 && cmake --build --preset m4-i2c100)")
endif()
set(EST consensus)
set(GEOMETRY "30;40;3000")
set(HOST_ARGS --i2c-khz;100)
include(${CMAKE_CURRENT_LIST_DIR}/run_twin_equal.cmake)
file(READ ${OUT}/report.json rep)
foreach(key loop_overruns watchdog_resets hardfaults)
  if(NOT rep MATCHES "\"${key}\": 0[,\n}]")
    message(FATAL_ERROR "100 kHz: ${key} is not 0: ${rep}")
  endif()
endforeach()
string(REGEX MATCH "\"loop_max_us\": ([0-9]+)" m "${rep}")
if(CMAKE_MATCH_1 STREQUAL "" OR CMAKE_MATCH_1 GREATER 20000)
  message(FATAL_ERROR "100 kHz: the worst loop (${CMAKE_MATCH_1} us) exceeds half the 40 ms period")
endif()
message(STATUS "100 kHz in the twin: rows equal host_sim --i2c-khz 100's, worst loop "
               "${CMAKE_MATCH_1} us of 40000")
