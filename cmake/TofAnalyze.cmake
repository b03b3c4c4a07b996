# `analyze` target (host presets): cppcheck and clang-tidy over the firmware
# code (estimator/, drivers/, hal/, firmware/) and the camera pose module (pose/),
# and cppcheck's MISRA C:2012 addon over estimator/ and drivers/, failing on any
# finding. MISRA findings pass only under a documented deviation
# (tools/misra/deviations.txt, reasons in docs/explanation/reliability.md), applied by
# tools/misra/misra_check.py, which names file:line:column and rule otherwise.
if(CMAKE_CROSSCOMPILING)
  return()
endif()
find_program(CPPCHECK cppcheck)
find_program(CLANG_TIDY clang-tidy)
set(TOF_ANALYZE_DIRS estimator pose drivers hal firmware)
set(analyze_cmds "")
set(analyze_files "")
foreach(dir IN LISTS TOF_ANALYZE_DIRS)
  file(GLOB_RECURSE f CONFIGURE_DEPENDS ${PROJECT_SOURCE_DIR}/${dir}/*.c)
  list(APPEND analyze_files ${f})
endforeach()
# The camera pose module is float C by design; it is analysed like the rest.
set(inc_args "")
file(GLOB inc_dirs LIST_DIRECTORIES true
  ${PROJECT_SOURCE_DIR}/*/include ${PROJECT_SOURCE_DIR}/*/*/include ${PROJECT_SOURCE_DIR}/*/*/*/include)
foreach(d IN LISTS inc_dirs)
  if(IS_DIRECTORY ${d} AND NOT d MATCHES "^${PROJECT_SOURCE_DIR}/build/")
    list(APPEND inc_args -I${d})
  endif()
endforeach()

# MISRA scope: the estimator (pose/ is float C, outside the rules by design)
# and the drivers, with the headers they include.
file(GLOB misra_files CONFIGURE_DEPENDS ${PROJECT_SOURCE_DIR}/estimator/src/*.c
     ${PROJECT_SOURCE_DIR}/drivers/*/*.c)
set(misra_inc -I${PROJECT_SOURCE_DIR}/estimator/include -I${PROJECT_SOURCE_DIR}/hal/include)
file(GLOB drv_inc LIST_DIRECTORIES true ${PROJECT_SOURCE_DIR}/drivers/*/include)
foreach(d IN LISTS drv_inc)
  list(APPEND misra_inc -I${d})
endforeach()
# Debian's cppcheck 2.10 ships the addon in its multiarch library directory.
find_file(TOF_MISRA_ADDON misra.py
  PATHS /usr/lib/${CMAKE_LIBRARY_ARCHITECTURE}/cppcheck/addons /usr/lib/cppcheck/addons
        /usr/share/cppcheck/addons /usr/local/share/cppcheck/addons
  NO_DEFAULT_PATH)
set(TOF_SYSTEM_PYTHON3 /usr/bin/python3)
set(misra_out ${PROJECT_BINARY_DIR}/misra-findings.txt)

if(NOT CPPCHECK OR NOT CLANG_TIDY)
  add_custom_target(analyze COMMAND ${CMAKE_COMMAND} -E echo
    "analyze: cppcheck or clang-tidy missing; run tools/setup.sh" COMMAND false)
elseif(NOT TOF_MISRA_ADDON OR NOT EXISTS ${TOF_SYSTEM_PYTHON3})
  add_custom_target(analyze COMMAND ${CMAKE_COMMAND} -E echo
    "analyze: cppcheck's MISRA addon (misra.py) or ${TOF_SYSTEM_PYTHON3} not found; "
    "install Debian's cppcheck and python3 (tools/setup.sh)" COMMAND false)
elseif(analyze_files)
  # No --cppcheck-build-dir: cppcheck 2.10 served stale addon results from it after a
  # source change (line numbers of the old file), so every run analyses afresh (~5 s).
  add_custom_target(analyze
    COMMAND ${CPPCHECK} --error-exitcode=1 --enable=warning,style,performance,portability
            --std=c11 --inline-suppr --quiet --suppress=missingIncludeSystem
            --suppress=unusedFunction --suppress=staticFunction
            ${inc_args} ${analyze_files}
    # MISRA: every finding to a file (cppcheck itself exits 0), then the gate.
    COMMAND ${CMAKE_COMMAND} -E rm -f ${misra_out}
    COMMAND ${CPPCHECK} --addon=${TOF_MISRA_ADDON} --addon-python=${TOF_SYSTEM_PYTHON3}
            --std=c11 --quiet --suppress=missingIncludeSystem
            --template={file}:{line}:{column}:{id} --output-file=${misra_out}
            ${misra_inc} ${misra_files}
    COMMAND ${TOF_SYSTEM_PYTHON3} ${PROJECT_SOURCE_DIR}/tools/misra/misra_check.py
            --root ${PROJECT_SOURCE_DIR}
            --deviations ${PROJECT_SOURCE_DIR}/tools/misra/deviations.txt
            --findings ${misra_out}
    COMMAND ${CLANG_TIDY} -p ${PROJECT_BINARY_DIR} --quiet --warnings-as-errors=*
            ${analyze_files}
    WORKING_DIRECTORY ${PROJECT_SOURCE_DIR}
    COMMENT "cppcheck + MISRA C:2012 (estimator/, drivers/) + clang-tidy over estimator/ pose/ drivers/ hal/ firmware/"
    VERBATIM)
else()
  add_custom_target(analyze COMMAND ${CMAKE_COMMAND} -E echo "analyze: no firmware sources yet")
endif()
