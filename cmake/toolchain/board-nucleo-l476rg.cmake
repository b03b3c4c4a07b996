# Board layer: ST NUCLEO-L476RG (STM32L476RG, Cortex-M4F), the interface MCU.
include(${CMAKE_CURRENT_LIST_DIR}/core-cortex-m4f.cmake)
set(TOF_BOARDS nucleo-l476rg)
set(TOF_BOARD_DIRS nucleo-l476rg)
