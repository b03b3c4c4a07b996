# The replay's distance mode (cmake -P): a trace at 2 m (a VL53L1X logging in long mode,
# readings above short mode's 1,360 mm) is replayed in long mode without being told, and
# answered; told short (--distance-mode or '# distance_mode=short'), every reading is
# flagged and nothing is answered; a bad distance_mode value is an error naming its line.
# Inputs: CMD (host_sim), WORK (a scratch directory).
set(rows "")
foreach(i RANGE 299)
  math(EXPR t "${i} * 50")
  math(EXPR a "2000 + (${i} * 7) % 5 - 2")
  math(EXPR b "2000 + (${i} * 3) % 5 - 2")
  math(EXPR c "2000 + (${i} * 11) % 5 - 2")
  math(EXPR d "2000 + (${i} * 13) % 5 - 2")
  string(APPEND rows "${t},${a},${b},${c},${d}\n")
endforeach()
set(head "# tof-trace v1\n# arm_mm=30\n# period_ms=50\n")
set(cols "t_ms,a_mm,b_mm,c_mm,d_mm\n")
file(WRITE ${WORK}/dm_long.csv "${head}${cols}${rows}")
file(WRITE ${WORK}/dm_short.csv "${head}# distance_mode=short\n${cols}${rows}")
file(WRITE ${WORK}/dm_bad.csv "${head}# distance_mode=medium\n${cols}${rows}")

function(replay name expect_mode expect_answered)
  execute_process(COMMAND ${CMD} replay ${ARGN} --quiet --report ${WORK}/${name}.json
                  RESULT_VARIABLE rc ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "${name}: exit status ${rc}: ${err}")
  endif()
  file(READ ${WORK}/${name}.json json)
  string(JSON mode GET "${json}" distance_mode mode)
  string(JSON answered GET "${json}" estimators consensus answered)
  if(NOT mode STREQUAL expect_mode)
    message(FATAL_ERROR "${name}: distance mode ${mode}, expected ${expect_mode}")
  endif()
  if(NOT answered EQUAL ${expect_answered})
    message(FATAL_ERROR "${name}: consensus answered ${answered}, expected ${expect_answered}")
  endif()
  set(last_err "${err}" PARENT_SCOPE)
endfunction()

replay(dm_auto long 1 ${WORK}/dm_long.csv)
if(NOT last_err MATCHES "distance mode long .*1200 readings above short mode's 1360 mm, the first at line 5 \\(sensor A\\)")
  message(FATAL_ERROR "dm_auto: no note of the chosen mode: ${last_err}")
endif()
replay(dm_option short 0 ${WORK}/dm_long.csv --distance-mode short)
replay(dm_meta short 0 ${WORK}/dm_short.csv)
replay(dm_meta_over long 1 ${WORK}/dm_short.csv --distance-mode long)

execute_process(COMMAND ${CMD} replay ${WORK}/dm_bad.csv --quiet RESULT_VARIABLE rc
                ERROR_VARIABLE err)
if(NOT rc EQUAL 1 OR NOT err MATCHES "dm_bad.csv:4: distance_mode must be short or long, got 'medium'")
  message(FATAL_ERROR "dm_bad: exit status ${rc}: ${err}")
endif()
