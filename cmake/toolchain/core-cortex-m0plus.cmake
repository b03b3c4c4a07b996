# Core layer: Cortex-M0+ (ARMv6-M): no FPU and no divide instruction.
include(${CMAKE_CURRENT_LIST_DIR}/arm-none-eabi.cmake)
set(TOF_CORE_FLAGS_cortex-m0plus -mcpu=cortex-m0plus -mthumb -mfloat-abi=soft)
set(TOF_CORE_NAME_cortex-m0plus cortex-m0plus)
list(APPEND TOF_CORES cortex-m0plus)
