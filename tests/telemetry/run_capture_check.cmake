# Agreement tests between the C protocol implementation and
# tools/tof_telemetry.py (ctest label integration). Invoked as
#   cmake -DMODE=c_to_python|python_to_c -DTOOL=<tlm_capture_tool> -DPYTHON=/usr/bin/python3
#         -DSCRIPT=<tools/tof_telemetry.py> -DWORK=<dir> -P run_capture_check.cmake
#
# c_to_python: the firmware's encoders write a capture (every message type, noise
#   and one frame of each malformed class); the Python decoder and the C decoder
#   must both print exactly the text expected from the encoded structs.
# python_to_c: the Python tool encodes commands from text; the firmware's decoder
#   and command parser must read back exactly these commands.

foreach(var MODE TOOL PYTHON SCRIPT WORK)
  if(NOT DEFINED ${var})
    message(FATAL_ERROR "run_capture_check.cmake: -D${var}=... is required")
  endif()
endforeach()
file(MAKE_DIRECTORY ${WORK})

function(run out_var)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    list(JOIN ARGN " " cmd)
    message(FATAL_ERROR "command failed (${rc}): ${cmd}\nstdout:\n${out}\nstderr:\n${err}")
  endif()
  set(${out_var} "${out}" PARENT_SCOPE)
endfunction()

function(expect_same what expected actual)
  if(NOT expected STREQUAL actual)
    file(WRITE ${WORK}/${what}.expected "${expected}")
    file(WRITE ${WORK}/${what}.actual "${actual}")
    execute_process(COMMAND diff -u ${WORK}/${what}.expected ${WORK}/${what}.actual
                    OUTPUT_VARIABLE diff)
    message(FATAL_ERROR "${what}: output differs from the expected text:\n${diff}")
  endif()
  string(REGEX MATCHALL "\n" lines "${actual}")
  list(LENGTH lines count)
  message(STATUS "${what}: ${count} lines identical")
endfunction()

if(MODE STREQUAL "c_to_python")
  run(ignored ${TOOL} write ${WORK}/capture.bin ${WORK}/expected.txt)
  file(READ ${WORK}/expected.txt expected)
  run(python_text ${PYTHON} ${SCRIPT} --file ${WORK}/capture.bin)
  expect_same(python_decoder "${expected}" "${python_text}")
  run(c_text ${TOOL} dump ${WORK}/capture.bin)
  expect_same(c_decoder "${expected}" "${c_text}")
  # --strict fails on this capture: it holds malformed frames on purpose.
  execute_process(COMMAND ${PYTHON} ${SCRIPT} --file ${WORK}/capture.bin --strict
                  RESULT_VARIABLE strict_rc OUTPUT_QUIET ERROR_QUIET)
  if(strict_rc EQUAL 0)
    message(FATAL_ERROR "--strict accepted a capture with malformed frames")
  endif()
  # CSV of the estimates: EST.csv's columns first (docs/reference/tools.md), one row per
  # estimate, a value and its sd empty when not estimated, why empty when ok.
  run(csv ${PYTHON} ${SCRIPT} --file ${WORK}/capture.bin --csv)
  string(REGEX MATCHALL "[^\n]+" rows "${csv}")
  list(GET rows 0 header)
  if(NOT header STREQUAL "t_ms,alpha_deg,beta_deg,distance_mm,status,alpha_sd_deg,beta_sd_deg,distance_sd_mm,why,temp_c,estimator,window,sensors,flatness_um,seq")
    message(FATAL_ERROR "unexpected CSV header: ${header}")
  endif()
  list(LENGTH rows row_count)
  list(GET rows 2 kalman_row)
  list(GET rows 6 invalid_row)
  list(GET rows 7 none_row)
  if(NOT row_count EQUAL 8
     OR NOT kalman_row STREQUAL "2000,0.999871,-0.001234,99998.765,ok,0.270123,0.000001,1.414,,-100.00,kalman,1,ABCD,-37,3"
     OR NOT invalid_row STREQUAL "8000,,0.000250,100.000,invalid,,0.000001,1.414,alpha-unobservable+paper-inconsistent,,kalman,4,A,,7"
     OR NOT none_row STREQUAL "10000,,,,invalid,,,,unobservable,,mean,5,none,,8")
    message(FATAL_ERROR "unexpected estimate CSV:\n${csv}")
  endif()
  # The plot of the estimates is written (a PNG signature, not empty).
  file(REMOVE ${WORK}/estimates.png)
  run(ignored ${PYTHON} ${SCRIPT} --file ${WORK}/capture.bin --plot ${WORK}/estimates.png)
  file(READ ${WORK}/estimates.png png_head LIMIT 8 HEX)
  if(NOT png_head STREQUAL "89504e470d0a1a0a")
    message(FATAL_ERROR "--plot did not write a PNG (${WORK}/estimates.png)")
  endif()
  # --live on the firmware-encoded capture, without a display (Agg): the picture with the
  # +-2 sd bands is drawn as the frames are read and saved at the end.
  file(REMOVE ${WORK}/live.png)
  run(live_text ${CMAKE_COMMAND} -E env MPLBACKEND=Agg ${PYTHON} ${SCRIPT} --file
      ${WORK}/capture.bin --live --plot ${WORK}/live.png)
  file(READ ${WORK}/live.png png_head LIMIT 8 HEX)
  if(NOT png_head STREQUAL "89504e470d0a1a0a")
    message(FATAL_ERROR "--live --plot did not write a PNG (${WORK}/live.png)")
  endif()
  expect_same(python_live_decoder "${expected}" "${live_text}")
elseif(MODE STREQUAL "python_to_c")
  run(ignored ${PYTHON} ${SCRIPT} --write-commands ${WORK}/commands.bin
      --send "set-window 50 sliding" --send "set-window 2" --send "estimator consensus-paper"
      --send start --send stop --send status --send "raw on" --send "raw off"
      --send "process-noise 0.5,0.010000" --send "process-noise auto" --send save)
  set(expected "seq=0 set-window window_n=50 mode=sliding
seq=1 set-window window_n=2 mode=tumbling
seq=2 select-estimator estimator=consensus-paper
seq=3 start
seq=4 stop
seq=5 status-request
seq=6 raw-stream enable=on
seq=7 raw-stream enable=off
seq=8 set-process-noise qd_mm2_per_s=0.500000 qt_mm2_per_s=0.010000 auto=no
seq=9 set-process-noise qd_mm2_per_s=0.000000 qt_mm2_per_s=0.000000 auto=yes
seq=10 save
# frames_ok=11 bad_crc=0 bad_length=0 unknown_type=0 truncated=0 out_of_range=0 discarded_bytes=0
")
  run(c_text ${TOOL} dump ${WORK}/commands.bin)
  expect_same(c_reads_python_commands "${expected}" "${c_text}")
  run(python_text ${PYTHON} ${SCRIPT} --file ${WORK}/commands.bin)
  expect_same(python_reads_python_commands "${expected}" "${python_text}")
  # Out-of-range commands are refused by the tool before anything is written.
  foreach(bad "set-window 1" "set-window 256" "set-window 10 diagonal" "estimator best" "raw maybe" "launch"
          "process-noise 1" "process-noise 0.0000001,0" "process-noise 4294.967296,0" "save now")
    execute_process(COMMAND ${PYTHON} ${SCRIPT} --write-commands ${WORK}/bad.bin --send "${bad}"
                    RESULT_VARIABLE bad_rc OUTPUT_VARIABLE bad_out ERROR_VARIABLE bad_err)
    if(bad_rc EQUAL 0 OR NOT bad_err MATCHES "--send")
      message(FATAL_ERROR "tof_telemetry.py accepted --send '${bad}' (rc ${bad_rc}): ${bad_err}")
    endif()
  endforeach()
else()
  message(FATAL_ERROR "run_capture_check.cmake: unknown MODE '${MODE}'")
endif()
