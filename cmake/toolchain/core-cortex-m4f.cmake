# Core layer: Cortex-M4 with the single-precision FPU (FPv4-SP), hard-float ABI.
include(${CMAKE_CURRENT_LIST_DIR}/arm-none-eabi.cmake)
set(TOF_CORE_FLAGS_cortex-m4f -mcpu=cortex-m4 -mthumb -mfloat-abi=hard -mfpu=fpv4-sp-d16)
set(TOF_CORE_NAME_cortex-m4f cortex-m4)
list(APPEND TOF_CORES cortex-m4f)
