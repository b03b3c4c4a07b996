# Board layer: ST NUCLEO-L476RG (STM32L476RG, Cortex-M4F), the interface MCU.
include(${CMAKE_CURRENT_LIST_DIR}/core-cortex-m4f.cmake)
set(TOF_BOARDS nucleo-l476rg)
set(TOF_BOARD_DIRS nucleo-l476rg)
# The flight image: the product's two estimators only (the paper's rule and the plain
# mean are comparison baselines for host_sim and the QEMU replay), windows up to 128 rows
# (the paper's protocol uses 100). Together they keep the image within the interface
# MCU's budget of 24 KiB flash and 8 KiB RAM (docs/firmware.md).
set(TOF_BOARD_DEFINITIONS "ATTITUDE_EST_BUILT=0x05u")
