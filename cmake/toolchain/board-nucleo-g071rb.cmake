# Board layer: ST NUCLEO-G071RB (STM32G071RB, Cortex-M0+): proves the fixed-point
# code needs neither an FPU nor a divide instruction.
include(${CMAKE_CURRENT_LIST_DIR}/core-cortex-m0plus.cmake)
set(TOF_BOARDS nucleo-g071rb)
set(TOF_BOARD_DIRS nucleo-g071rb)
