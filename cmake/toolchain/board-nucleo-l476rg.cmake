# Board layer: ST NUCLEO-L476RG (STM32L476RG, Cortex-M4F), the interface MCU.
include(${CMAKE_CURRENT_LIST_DIR}/core-cortex-m4f.cmake)
set(TOF_BOARDS nucleo-l476rg)
set(TOF_BOARD_DIRS nucleo-l476rg)
# The flight image builds the product's two estimators only: the paper's rule and the
# plain mean are comparison baselines for host_sim and the QEMU replay. Saves 1.9 KB of
# flash toward the interface MCU's budget (docs/benchmarks.md).
set(TOF_BOARD_DEFINITIONS "ATTITUDE_EST_BUILT=0x05u")
