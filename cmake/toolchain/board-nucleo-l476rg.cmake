# Board layer: ST NUCLEO-L476RG (STM32L476RG, Cortex-M4F), the interface MCU.
include(${CMAKE_CURRENT_LIST_DIR}/core-cortex-m4f.cmake)
set(TOF_BOARDS nucleo-l476rg)
set(TOF_BOARD_DIRS nucleo-l476rg)
# The flight image (cmake/TofOptions.cmake): the product's two estimators only (the paper's
# rule and the plain mean are comparison baselines for host_sim, the QEMU replay and the
# benchmarks; docs/reference/performance.md has the flash each choice costs).
set(TOF_ESTIMATORS_DEFAULT consensus kalman)
# Link-time optimisation (cmake/TofBuild.cmake): what it saves and costs in flash and stack,
# tools/image_budget.py (the `budget` target).
set(TOF_LTO_DEFAULT ON)
