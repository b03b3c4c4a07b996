# What an image contains: the attitude estimators and the Kalman filter's forms.
# Checked at configure time; the same options drive every image of a preset (firmware,
# replay and benchmark images) and the host build. A board layer of the toolchain
# (cmake/toolchain/board-*.cmake) may set TOF_ESTIMATORS_DEFAULT and
# TOF_KALMAN_FORMS_DEFAULT for its images; -D on the command line overrides both.
#
#   TOF_ESTIMATORS    any of consensus (the product rule, required by the firmware),
#                     consensus-paper (the published rule), kalman, mean (the plain
#                     average): the paper rule and the mean are baselines for host_sim,
#                     the QEMU replay and the benchmarks.
#   TOF_KALMAN_FORMS  any of tracking (the covariance form: Q > 0, and Q = 0 as well) and
#                     information (Q = 0 only, with its fast solve); ignored without kalman.
#                     An image with both runs the information form for Q = 0 (the host's
#                     golden outputs); with tracking only, the tracking form runs Q = 0 too.
#
# Flight image (NUCLEO-L476RG): consensus;kalman with tracking (docs/benchmarks.md).
set(tof_all_estimators consensus consensus-paper kalman mean) # ATTITUDE_EST_BIT order
set(tof_all_kalman_forms tracking information)

if(NOT DEFINED TOF_ESTIMATORS_DEFAULT)
  set(TOF_ESTIMATORS_DEFAULT ${tof_all_estimators})
endif()
if(NOT DEFINED TOF_KALMAN_FORMS_DEFAULT)
  set(TOF_KALMAN_FORMS_DEFAULT ${tof_all_kalman_forms})
endif()
set(TOF_ESTIMATORS "${TOF_ESTIMATORS_DEFAULT}" CACHE STRING
    "Attitude estimators built: any of consensus;consensus-paper;kalman;mean")
set(TOF_KALMAN_FORMS "${TOF_KALMAN_FORMS_DEFAULT}" CACHE STRING
    "Kalman filter forms built: any of tracking;information")

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
foreach(name IN LISTS TOF_KALMAN_FORMS)
  if(NOT name IN_LIST tof_all_kalman_forms)
    message(FATAL_ERROR "TOF_KALMAN_FORMS: unknown form '${name}' (known: tracking;information)")
  endif()
endforeach()
set(TOF_KALMAN_TRACKING OFF)
set(TOF_KALMAN_INFORMATION OFF)
if("kalman" IN_LIST TOF_ESTIMATORS)
  if(NOT TOF_KALMAN_FORMS)
    message(FATAL_ERROR "TOF_ESTIMATORS has kalman but TOF_KALMAN_FORMS is empty: "
                        "build tracking, information or both")
  endif()
  if("tracking" IN_LIST TOF_KALMAN_FORMS)
    set(TOF_KALMAN_TRACKING ON)
  endif()
  if("information" IN_LIST TOF_KALMAN_FORMS)
    set(TOF_KALMAN_INFORMATION ON)
  endif()
else()
  set(TOF_KALMAN_TRACKING ON) # never called without kalman, but the filter must compile:
                              # the smaller form, unreferenced and dropped by the linker
endif()

# The definitions only when they differ from the headers' defaults (everything built), so
# a test may compile its own copy of a file with other definitions (tests/estimator).
if(NOT tof_est_mask EQUAL 15)
  add_compile_definitions(ATTITUDE_EST_BUILT=${tof_est_mask}u)
endif()
if(NOT (TOF_KALMAN_TRACKING AND TOF_KALMAN_INFORMATION))
  if(TOF_KALMAN_TRACKING)
    add_compile_definitions(KALMAN_TRACKING_BUILT=1 KALMAN_INFORMATION_BUILT=0)
  else()
    add_compile_definitions(KALMAN_TRACKING_BUILT=0 KALMAN_INFORMATION_BUILT=1)
  endif()
endif()
set(TOF_FULL_ESTIMATOR_SET OFF)
if(tof_est_mask EQUAL 15 AND TOF_KALMAN_TRACKING AND TOF_KALMAN_INFORMATION)
  set(TOF_FULL_ESTIMATOR_SET ON)
endif()
message(STATUS "Estimators built: ${TOF_ESTIMATORS} (ATTITUDE_EST_BUILT ${tof_est_mask}); "
               "Kalman forms: tracking ${TOF_KALMAN_TRACKING}, information "
               "${TOF_KALMAN_INFORMATION}")
