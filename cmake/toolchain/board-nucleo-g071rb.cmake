# Board layer: ST NUCLEO-G071RB (STM32G071RB, Cortex-M0+): proves the fixed-point
# code needs neither an FPU nor a divide instruction.
include(${CMAKE_CURRENT_LIST_DIR}/core-cortex-m0plus.cmake)
set(TOF_BOARDS nucleo-g071rb)
set(TOF_BOARD_DIRS nucleo-g071rb)
# The same flight image as the NUCLEO-L476RG's (board-nucleo-l476rg.cmake): the product's two
# estimators only; the paper's rule and the plain mean are host_sim's and QEMU's baselines.
set(TOF_ESTIMATORS_DEFAULT consensus kalman)
# Link-time optimisation (cmake/TofBuild.cmake): what it saves and costs in flash and stack,
# tools/image_budget.py (the `budget` target).
set(TOF_LTO_DEFAULT ON)
