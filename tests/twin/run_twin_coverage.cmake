# Line coverage of boards/stm32/ by the flight ELF under the twin (goal >= 90 %): the demo
# run, a fault run, spurious BERR, a command run (USART RX), saves (one cut by a power loss:
# the flash's ECC path) and the clock-switch failure,
# their executed addresses merged and mapped on the ELF's line table
# (tools/twin_coverage.py names every line not executed).
file(MAKE_DIRECTORY ${OUT})
set(runs
  "--strict"
  "--strict --faults nack=0.01,reset=0.0005,stuck=0.0005 --seed 7"
  "--strict --spurious-berr 20000"
  "--strict --window 50 --mode sliding --late-command"
  "--strict --window 50 --mode sliding --late-command --save --max-sim-s 3"
  "--strict --window 60 --late-command --save --flash-cut 4 --max-sim-s 3"
  "--strict --hsi-fail --max-sim-s 0.3")
set(files "")
set(k 0)
foreach(run IN LISTS runs)
  separate_arguments(args UNIX_COMMAND "${run}")
  execute_process(COMMAND ${TWIN} ${ELF} ${TRACE} ${args} --out ${OUT}/est${k}.csv
                          --coverage ${OUT}/cov${k}.txt
                  RESULT_VARIABLE rc OUTPUT_QUIET ERROR_QUIET)
  if(NOT EXISTS ${OUT}/cov${k}.txt)
    message(FATAL_ERROR "run '${run}' wrote no coverage (${rc})")
  endif()
  list(APPEND files ${OUT}/cov${k}.txt)
  math(EXPR k "${k} + 1")
endforeach()
execute_process(COMMAND /usr/bin/python3 ${SRC}/tools/twin_coverage.py --elf ${ELF}
                        --dir ${SRC}/boards/stm32 --min 90 --json ${OUT}/coverage.json ${files}
                WORKING_DIRECTORY ${SRC} RESULT_VARIABLE rc OUTPUT_VARIABLE out)
message("${out}")
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "boards/stm32 line coverage under the twin below 90 %")
endif()
