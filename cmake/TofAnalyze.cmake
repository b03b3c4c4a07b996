# `analyze` target (host presets): cppcheck and clang-tidy over the firmware
# code (estimator/, drivers/, hal/, firmware/), failing on any finding.
if(CMAKE_CROSSCOMPILING)
  return()
endif()
find_program(CPPCHECK cppcheck)
find_program(CLANG_TIDY clang-tidy)
set(TOF_ANALYZE_DIRS estimator drivers hal firmware)
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
if(NOT CPPCHECK OR NOT CLANG_TIDY)
  add_custom_target(analyze COMMAND ${CMAKE_COMMAND} -E echo
    "analyze: cppcheck or clang-tidy missing; run tools/setup.sh" COMMAND false)
elseif(analyze_files)
  add_custom_target(analyze
    COMMAND ${CPPCHECK} --error-exitcode=1 --enable=warning,style,performance,portability
            --std=c11 --inline-suppr --quiet --suppress=missingIncludeSystem
            --suppress=unusedFunction --suppress=staticFunction
            ${inc_args} ${analyze_files}
    COMMAND ${CLANG_TIDY} -p ${PROJECT_BINARY_DIR} --quiet --warnings-as-errors=*
            ${analyze_files}
    WORKING_DIRECTORY ${PROJECT_SOURCE_DIR}
    COMMENT "cppcheck + clang-tidy over estimator/ drivers/ hal/ firmware/"
    VERBATIM)
else()
  add_custom_target(analyze COMMAND ${CMAKE_COMMAND} -E echo "analyze: no firmware sources yet")
endif()
