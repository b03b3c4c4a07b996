# Core layer: Cortex-M0+ (ARMv6-M): no FPU and no divide instruction.
include(${CMAKE_CURRENT_LIST_DIR}/arm-none-eabi.cmake)
# -fno-jump-tables: ARMv6-M has no TBB/TBH, so GCC's switch tables go through libgcc's
# __gnu_thumb1_case_* helpers; compare chains are smaller here (the NUCLEO-G071RB image
# 48 B smaller, which its 64 KiB budget needed).
set(TOF_CORE_FLAGS_cortex-m0plus -mcpu=cortex-m0plus -mthumb -mfloat-abi=soft -fno-jump-tables)
set(TOF_CORE_NAME_cortex-m0plus cortex-m0plus)
list(APPEND TOF_CORES cortex-m0plus)
# Under link-time optimisation GCC 12.2 anchors the whole program's static data on one
# section anchor and emits Thumb-1 loads at offsets beyond their 5-bit immediate (the
# assembler's "invalid offset, value too big"): no section anchors for this core then.
set(TOF_CORE_LTO_FLAGS_cortex-m0plus -fno-section-anchors)
