# Print flash (text + data) and RAM (data + bss, stack included) per image.
# Usage: cmake -DSIZE=arm-none-eabi-size -DDIR=<build dir> -P print_size.cmake
include(${CMAKE_CURRENT_LIST_DIR}/image_size.cmake)
file(GLOB_RECURSE elfs ${DIR}/*.elf)
list(SORT elfs)
message("image                                 flash_bytes  ram_bytes")
foreach(elf IN LISTS elfs)
  tof_image_size(${SIZE} ${elf} flash ram)
  get_filename_component(name ${elf} NAME)
  string(LENGTH "${name}" n)
  math(EXPR pad "38 - ${n}")
  if(pad LESS 1)
    set(pad 1) # long names (the twin's test builds) still get one space
  endif()
  string(REPEAT " " ${pad} spaces)
  message("${name}${spaces}${flash}  ${ram}")
endforeach()
