# The saved settings in the twin (docs/explanation/boards.md "Records"), strict: -DTWIN -DELF -DTRACE -DOUT.
# 1. set-window 50 sliding, save; the record pages kept in a file (a reflash keeps them).
# 2. a new boot from those pages: the status frame reports the record loaded and 50 sliding.
# 3. set-window 60 tumbling and save again, the power cut at each step of that save (each
#    page erase, each double-word) and the MCU booted again: the record is the old one (50
#    sliding) or the new one (60 tumbling), never lost, never mixed; both are seen.
if(NOT EXISTS "${ELF}")
  message(FATAL_ERROR "twin test: ${ELF} missing: build the m4 preset first")
endif()
file(MAKE_DIRECTORY ${OUT})
# The settings record alone: the trace without its calibration keys (a calibrated trace's
# record would also hold the calibration, which twin.calibration_* test).
file(READ ${TRACE} text)
string(REGEX REPLACE "# (offset_mm|offset_sd_mm|gain|gain_sd|calibration)=[^\n]*\n" "" text
                     "${text}")
file(WRITE ${OUT}/uncalibrated.csv "${text}")
set(TRACE ${OUT}/uncalibrated.csv)

function(twin_run name)
  execute_process(COMMAND ${TWIN} ${ELF} ${TRACE} --strict --late-command --max-sim-s 3
                          ${ARGN} --out ${OUT}/${name}.csv --report ${OUT}/${name}.json
                  RESULT_VARIABLE rc ERROR_VARIABLE err)
  if(err MATCHES "violat|HardFault at|stopped:")
    message(FATAL_ERROR "${name}: ${err}")
  endif()
  file(READ ${OUT}/${name}.json rep)
  foreach(key record_state boot_window boot_sliding boots hardfaults flash_cuts flash_programs)
    if(NOT rep MATCHES "\"${key}\": ([0-9]+)")
      message(FATAL_ERROR "${name}: report has no '${key}'")
    endif()
    set(${key} ${CMAKE_MATCH_1} PARENT_SCOPE)
  endforeach()
endfunction()

twin_run(save --window 50 --mode sliding --save --flash-out ${OUT}/pages.bin)
if(NOT flash_programs GREATER 0 OR NOT record_state EQUAL 0)
  message(FATAL_ERROR "save: nothing programmed (${flash_programs}) or a record before it")
endif()
twin_run(reboot --window 50 --mode sliding --flash-in ${OUT}/pages.bin)
if(NOT record_state EQUAL 1 OR NOT boot_window EQUAL 50 OR NOT boot_sliding EQUAL 1)
  message(FATAL_ERROR "after the reset: record ${record_state}, window ${boot_window}, "
                      "sliding ${boot_sliding}; expected 1 (loaded), 50, 1")
endif()
message(STATUS "saved settings back after the reset: window 50 sliding")

set(seen_old 0)
set(seen_new 0)
# one save of the settings record: the other page is blank (the first save's last step
# erased it), so no erase before the copy: 6 double-words (12 + 28 + 2 bytes: header, the
# settings section v2, CRC), then the old page's erase, in the background over the loop
# iterations after the answer
foreach(k RANGE 0 6)
  twin_run(cut${k} --window 60 --save --flash-in ${OUT}/pages.bin --flash-cut ${k})
  if(NOT flash_cuts EQUAL 1 OR NOT boots EQUAL 2 OR NOT hardfaults EQUAL 0)
    message(FATAL_ERROR "cut ${k}: cuts ${flash_cuts}, boots ${boots}, hardfaults ${hardfaults}")
  endif()
  if(NOT record_state EQUAL 1)
    message(FATAL_ERROR "cut ${k}: the record is lost (state ${record_state})")
  endif()
  if(boot_window EQUAL 50 AND boot_sliding EQUAL 1)
    math(EXPR seen_old "${seen_old} + 1")
  elseif(boot_window EQUAL 60 AND boot_sliding EQUAL 0)
    math(EXPR seen_new "${seen_new} + 1")
  else()
    message(FATAL_ERROR "cut ${k}: window ${boot_window} sliding ${boot_sliding}: mixed")
  endif()
  message(STATUS "cut at flash step ${k}: window ${boot_window}")
endforeach()
if(seen_old EQUAL 0 OR seen_new EQUAL 0)
  message(FATAL_ERROR "old ${seen_old} times, new ${seen_new}: expected both")
endif()
