# Core layer: Cortex-M3 (ARMv7-M, hardware divide, no FPU): float is software.
include(${CMAKE_CURRENT_LIST_DIR}/arm-none-eabi.cmake)
set(TOF_CORE_FLAGS_cortex-m3 -mcpu=cortex-m3 -mthumb -mfloat-abi=soft)
set(TOF_CORE_NAME_cortex-m3 cortex-m3)
list(APPEND TOF_CORES cortex-m3)
