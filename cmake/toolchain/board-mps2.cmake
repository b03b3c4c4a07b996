# Board layer: QEMU's Arm MPS2 boards, mps2-an386 (Cortex-M4) and mps2-an385
# (Cortex-M3), run with semihosting. One preset, two cores.
include(${CMAKE_CURRENT_LIST_DIR}/core-cortex-m4f.cmake)
include(${CMAKE_CURRENT_LIST_DIR}/core-cortex-m3.cmake)
set(TOF_BOARDS mps2-an386 mps2-an385)
set(TOF_BOARD_DIRS mps2)
