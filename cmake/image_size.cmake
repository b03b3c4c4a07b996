# An image's flash (text + data) and RAM (data + bss, the stack the linker script reserves
# included), from `size -B`: one reading for cmake/print_size.cmake and check_image.cmake.
function(tof_image_size size elf flash_var ram_var)
  execute_process(COMMAND ${size} -B ${elf} OUTPUT_VARIABLE out RESULT_VARIABLE rc)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "size failed on ${elf}")
  endif()
  string(REGEX MATCH "\n[ \t]*([0-9]+)[ \t]+([0-9]+)[ \t]+([0-9]+)" m "${out}")
  math(EXPR flash "${CMAKE_MATCH_1} + ${CMAKE_MATCH_2}")
  math(EXPR ram "${CMAKE_MATCH_2} + ${CMAKE_MATCH_3}")
  set(${flash_var} ${flash} PARENT_SCOPE)
  set(${ram_var} ${ram} PARENT_SCOPE)
endfunction()
