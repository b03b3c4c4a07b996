# What an image contains: the attitude estimators.
# Checked at configure time; the same options drive every image of a preset (firmware,
# replay and benchmark images) and the host build. A board layer of the toolchain
# (cmake/toolchain/board-*.cmake) may set TOF_ESTIMATORS_DEFAULT for its images; -D on the
# command line overrides it.
#
#   TOF_ESTIMATORS    any of consensus (the product rule, required by the firmware),
#                     consensus-paper (the published rule), kalman, mean (the plain
#                     average): the paper rule and the mean are baselines for host_sim,
#                     the QEMU replay and the benchmarks.
#
# The Kalman filter is one filter for any Q, the same code in every build (no option).
# Flight image (NUCLEO-L476RG): consensus;kalman (docs/reference/performance.md).
set(tof_all_estimators consensus consensus-paper kalman mean) # ATTITUDE_EST_BIT order

if(NOT DEFINED TOF_ESTIMATORS_DEFAULT)
  set(TOF_ESTIMATORS_DEFAULT ${tof_all_estimators})
endif()
set(TOF_ESTIMATORS "${TOF_ESTIMATORS_DEFAULT}" CACHE STRING
    "Attitude estimators built: any of consensus;consensus-paper;kalman;mean")

set(tof_est_mask 0)
set(tof_bit 1)
foreach(name IN LISTS tof_all_estimators)
  if(name IN_LIST TOF_ESTIMATORS)
    math(EXPR tof_est_mask "${tof_est_mask} | ${tof_bit}")
  endif()
  math(EXPR tof_bit "${tof_bit} * 2")
endforeach()
foreach(name IN LISTS TOF_ESTIMATORS)
  if(NOT name IN_LIST tof_all_estimators)
    message(FATAL_ERROR "TOF_ESTIMATORS: unknown estimator '${name}' "
                        "(known: consensus;consensus-paper;kalman;mean)")
  endif()
endforeach()
if(NOT "consensus" IN_LIST TOF_ESTIMATORS)
  message(FATAL_ERROR "TOF_ESTIMATORS='${TOF_ESTIMATORS}': the firmware's primary estimate is "
                      "the product consensus; it must be built")
endif()
# The definition only when it differs from the header's default (everything built), so
# a test may compile its own copy of a file with other definitions (tests/estimator).
if(NOT tof_est_mask EQUAL 15)
  add_compile_definitions(ATTITUDE_EST_BUILT=${tof_est_mask}u)
endif()
set(TOF_FULL_ESTIMATOR_SET OFF)
if(tof_est_mask EQUAL 15)
  set(TOF_FULL_ESTIMATOR_SET ON)
endif()
message(STATUS "Estimators built: ${TOF_ESTIMATORS} (ATTITUDE_EST_BUILT ${tof_est_mask})")

# The sensors' I2C bus clock of the board images (kHz): 400 (Fast-mode, the default) or 100
# (Standard-mode, for a long harness). The board programs its I2C timing for it, and the
# firmware's default period is one the bus can carry (firmware/config.h, tof_app_bus_fits()).
# host_sim takes the same choice at run time (replay --i2c-khz).
set(TOF_I2C_KHZ 400 CACHE STRING "I2C bus clock of the board images, kHz: 100 or 400")
if(NOT TOF_I2C_KHZ MATCHES "^(100|400)$")
  message(FATAL_ERROR "TOF_I2C_KHZ='${TOF_I2C_KHZ}': 100 or 400")
endif()
add_compile_definitions(TOF_I2C_KHZ=${TOF_I2C_KHZ})
