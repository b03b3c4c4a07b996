# Image checks, run after every firmware link (cmake -P):
#   no heap: malloc/free/... or _sbrk linked in  -> build fails
#   NO_FLOAT: any soft-float or FPU helper linked -> build fails
#   FLIGHT_BUDGET: flash (text + data) above 64 KiB or RAM (data + bss, the stack the
#   linker script reserves included) above 16 KiB -> build fails (docs/reference/performance.md)
# Usage: cmake -DNM=... -DELF=... [-DNO_FLOAT=1] [-DSIZE=... -DFLIGHT_BUDGET=1] -P check_image.cmake
execute_process(COMMAND ${NM} --defined-only --format=posix ${ELF}
                OUTPUT_VARIABLE syms RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "check_image: ${NM} failed on ${ELF}")
endif()
string(REPLACE "\n" ";" lines "${syms}")
set(heap_re "^(_?_?malloc|_?_?free|_?_?calloc|_?_?realloc|_malloc_r|_free_r|_calloc_r|_realloc_r|_sbrk|_sbrk_r|memalign|_memalign_r|posix_memalign) ")
# EABI float helpers (__aeabi_f*, __aeabi_d*, conversions to/from float) and
# libgcc's generic soft-float names (__addsf3, __muldf3, __fixdfsi, ...).
set(float_re "^(__aeabi_(f|d|[iu]2[fd]|l2[fd]|ul2[fd])[a-z0-9_]*|__[a-z]+[sd]f[0-9]?|__[a-z]+[sd]f[a-z]+[0-9]?) ")
set(bad "")
foreach(line IN LISTS lines)
  if(line MATCHES "${heap_re}")
    string(REGEX REPLACE " .*" "" s "${line}")
    list(APPEND bad "heap function '${s}'")
  elseif(NO_FLOAT AND line MATCHES "${float_re}")
    string(REGEX REPLACE " .*" "" s "${line}")
    list(APPEND bad "floating-point helper '${s}'")
  endif()
endforeach()
if(bad)
  list(JOIN bad "\n  " msg)
  message(FATAL_ERROR "check_image: ${ELF} links forbidden code:\n  ${msg}\n"
          "Firmware images use no heap; NO_FLOAT images use no floating point.")
endif()
if(FLIGHT_BUDGET)
  include(${CMAKE_CURRENT_LIST_DIR}/image_size.cmake)
  tof_image_size(${SIZE} ${ELF} flash ram)
  if(flash GREATER 65536 OR ram GREATER 16384)
    message(FATAL_ERROR "check_image: ${ELF} is over the flight budget: flash ${flash} B "
            "(at most 65536), RAM ${ram} B with the stack (at most 16384)")
  endif()
endif()
