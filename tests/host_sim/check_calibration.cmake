# host_sim replay's head calibration reaches the firmware: from the trace's keys,
# from calibration=FILE beside the trace, from --calibration (which wins), or none; bad
# values are errors naming file, line and column. Read back from the report's
# "calibration", which is what the firmware's boot put into attitude_config.calibration.
# Inputs: CMD (host_sim), DEMO (a trace to take rows from), WORK (a scratch directory).
file(MAKE_DIRECTORY ${WORK}/cal)
file(STRINGS ${DEMO} lines)
list(SUBLIST lines 0 3 head)  # version, arm_mm, period_ms
set(at 0)
foreach(line IN LISTS lines)  # the header line: the rows start there
  if(line MATCHES "^t_ms")
    break()
  endif()
  math(EXPR at "${at} + 1")
endforeach()
list(SUBLIST lines ${at} 301 body)
string(REPLACE ";" "\n" head "${head}")
string(REPLACE ";" "\n" body "${body}")

function(write_trace name meta)
  file(WRITE ${WORK}/cal/${name}.csv "${head}\n${meta}${body}\n")
endfunction()

function(replay name expect_rc expect_err expect_json)
  execute_process(COMMAND ${CMD} replay ${WORK}/cal/${name}.csv --window 50 --quiet
                          --report ${WORK}/cal/${name}.json ${ARGN}
                  RESULT_VARIABLE rc ERROR_VARIABLE err TIMEOUT 300)
  if(NOT rc STREQUAL "${expect_rc}")
    message(FATAL_ERROR "${name}: exit status ${rc}, expected ${expect_rc}\n${err}")
  endif()
  if(NOT err MATCHES "${expect_err}")
    message(FATAL_ERROR "${name}: stderr does not match '${expect_err}':\n${err}")
  endif()
  if(expect_rc EQUAL 0)
    file(READ ${WORK}/cal/${name}.json json)
    if(NOT json MATCHES "${expect_json}")
      message(FATAL_ERROR "${name}: report does not match '${expect_json}':\n${json}")
    endif()
  endif()
endfunction()

set(offsets "# offset_mm=1.5,-0.8,-1.2,0.6\n# offset_sd_mm=0.03,0.03,0.03,0.0305\n")
file(WRITE ${WORK}/cal/head.cal "# tof-head-cal v1\n# offset_mm=2.5,-0.8,-1.2,0.6\n"
     "# offset_sd_mm=0.03,0.03,0.03,0.03\n# gain=1.001,0.999,1,1.0000005\n"
     "# gain_sd=0.0001,0.0001,0.0001,0.0001\n# offset_gain_corr=-0.9,-0.9,-0.9,-0.9\n")
file(WRITE ${WORK}/cal/wide.cal "# tof-head-cal v1\n# offset_mm=0,0,0,0\n"
     "# offset_sd_mm=0,0,0,0\n# gain=1,1,1.5,1\n# gain_sd=0,0,0,0\n")

write_trace(none "")
replay(none 0 "" "\"calibration\": {\"source\": \"none \\(uncalibrated\\)\", \"state\": \"none\", \"calibrated\": false}")
write_trace(explicit_none "# calibration=none\n")
replay(explicit_none 0 "" "\"state\": \"none\", \"calibrated\": false")
write_trace(inline "${offsets}")
replay(inline 0 "" "\"state\": \"applied\", \"calibrated\": true, \"offset_um\": \\[1500, -800, -1200, 600\\], \"gain_ppm\": \\[0, 0, 0, 0\\], \"offset_sd_um\": \\[30, 30, 30, 31\\], \"gain_sd_ppm\": \\[17321, 17321, 17321, 17321\\]")
# the option wins over the trace's keys
replay(inline 0 "" "\"offset_um\": \\[2500, -800, -1200, 600\\], \"gain_ppm\": \\[1000, -1000, 0, 1\\], \"offset_sd_um\": \\[30, 30, 30, 30\\], \"gain_sd_ppm\": \\[100, 100, 100, 100\\], \"offset_gain_corr_q15\": \\[-29491, -29491, -29491, -29491\\]"
       --calibration ${WORK}/cal/head.cal)
write_trace(by_file "# calibration=head.cal\n")
replay(by_file 0 "" "\"source\": \"[^\"]*cal/head.cal\", \"state\": \"applied\", \"calibrated\": true, \"offset_um\": \\[2500,")
# bad input: file, line and column
write_trace(bad_value "# offset_mm=1.5,-0.8,x,0.6\n# offset_sd_mm=0,0,0,0\n")
replay(bad_value 1 "bad_value.csv:4:22: offset_mm: not a plain decimal" "")
write_trace(half "# offset_mm=1.5,-0.8,-1.2,0.6\n")
replay(half 1 "half.csv:4:1: offset_mm and offset_sd_mm come together" "")
write_trace(missing_file "# calibration=nowhere.cal\n")
replay(missing_file 1 "nowhere.cal" "")
replay(none 1 "--calibration: .*wide.cal:4: gain: a gain within 0.9..1.1" "" --calibration ${WORK}/cal/wide.cal)
# What a HEAD.cal says it was made in (tools/tof_telemetry.py --read-cal writes these keys):
# the simulated head is the file's head_id; another distance mode is refused by the boot as
# the flight unit would (a warning, the replay uncalibrated), a bad value is an error.
file(READ ${WORK}/cal/head.cal base)
file(WRITE ${WORK}/cal/head7.cal "${base}# head_id=7\n")
replay(none 0 "" "\"state\": \"applied\", \"calibrated\": true" --calibration ${WORK}/cal/head7.cal)
file(WRITE ${WORK}/cal/long.cal "${base}# distance_mode=long\n")
replay(none 0 "warning: .*long.cal was made in another distance mode"
       "\"state\": \"other-mode\", \"calibrated\": false" --calibration ${WORK}/cal/long.cal)
file(WRITE ${WORK}/cal/badid.cal "${base}# head_id=-1\n")
replay(none 1 "badid.cal: head_id '-1' is not an integer" "" --calibration ${WORK}/cal/badid.cal)
