# Regenerates the demo trace with scene_tool and compares it with the bundled one.
execute_process(
  COMMAND ${TOOL} scenario realnoise-demo --seed 20250921 --trace-out ${OUT}
  RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "scene_tool failed (${rc})")
endif()
execute_process(COMMAND ${CMAKE_COMMAND} -E compare_files ${OUT} ${WANT} RESULT_VARIABLE same)
if(NOT same EQUAL 0)
  message(FATAL_ERROR "${OUT} differs from ${WANT}: the scene code changed what the demo "
                      "trace would be; regenerate it as traces/demo/README.md says")
endif()
