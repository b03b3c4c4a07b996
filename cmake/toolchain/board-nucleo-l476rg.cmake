# Board layer: ST NUCLEO-L476RG (STM32L476RG, Cortex-M4F), the interface MCU.
include(${CMAKE_CURRENT_LIST_DIR}/core-cortex-m4f.cmake)
set(TOF_BOARDS nucleo-l476rg)
set(TOF_BOARD_DIRS nucleo-l476rg)
# The flight image builds the product's two estimators only: the paper's rule and the
# plain mean are comparison baselines for host_sim and the QEMU replay (1.9 KB of flash).
# Its Kalman filter runs the static protocol (Q = 0, the information form) only: the
# covariance form for Q > 0 is not built (KALMAN_COVARIANCE_BUILT, estimator/kalman.h;
# docs/benchmarks.md has the flash it saves).
set(TOF_BOARD_DEFINITIONS "ATTITUDE_EST_BUILT=0x05u;KALMAN_COVARIANCE_BUILT=0")
