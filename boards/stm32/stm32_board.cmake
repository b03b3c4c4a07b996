# tof_stm32_board(BOARD CORE IRQS OPENOCD_CFG LD UART_IRQ n [NO_FLOAT]): the firmware image of an STM32
# NUCLEO board (the shared startup, STM32 drivers and board HAL, the board's own
# board_desc.c and linker script <part>.ld in its folder) and its `flash` target
# (openocd over the board's ST-LINK). UART_IRQ: the NVIC number of the telemetry USART's
# interrupt, whose vector the shared startup points at Uart_IRQHandler (stm32_board.c).
#
# `budget`: the flight image's flash and RAM by part (tools/image_budget.py; configure with
# -DTOF_BUDGET_ARGS=--markdown or --files for the docs' tables).
#
# TEST_VARIANTS v...: also firmware-<board>-<v>.elf, the same image built with TWIN_TEST_<V>
# defined (test builds for the twin, tests/twin); the flight image is never changed by them.
function(tof_stm32_board board core irqs openocd_cfg ld)
  cmake_parse_arguments(ARG "NO_FLOAT;SMALL_MEM" "UART_IRQ" "TEST_VARIANTS" ${ARGN})
  # SMALL_MEM: the byte-loop memcpy, memmove and memset of boards/cortex-m/mem.c in place of
  # newlib-nano's word-copying ones (416 B less), for a board whose flash budget needs it.
  set(small_mem "")
  if(ARG_SMALL_MEM)
    set(small_mem ${PROJECT_SOURCE_DIR}/boards/cortex-m/mem.c)
  endif()
  if(NOT DEFINED ARG_UART_IRQ)
    message(FATAL_ERROR "tof_stm32_board(${board}): UART_IRQ missing")
  endif()
  set(no_float "")
  if(ARG_NO_FLOAT)
    set(no_float NO_FLOAT)
  endif()
  set(image firmware-${board})
  set(stm32 ${PROJECT_SOURCE_DIR}/boards/stm32)
  foreach(variant "" ${ARG_TEST_VARIANTS})
    set(name ${image})
    if(variant)
      set(name ${image}-${variant})
    endif()
    tof_image(${name} CORE ${core} ${no_float} FLIGHT
      LINKER_SCRIPT ${CMAKE_CURRENT_SOURCE_DIR}/${ld}
      SOURCES ${PROJECT_SOURCE_DIR}/boards/cortex-m/startup.c ${small_mem}
              ${stm32}/stm32_usart.c ${stm32}/stm32_gpio.c ${stm32}/stm32_i2c.c
              ${stm32}/stm32_systick_time.c ${stm32}/stm32_iwdg.c ${stm32}/stm32_flash.c ${stm32}/stm32_adc_temp.c ${stm32}/stm32_adc_g0_temp.c
              ${stm32}/stm32_board.c
              ${stm32}/stm32_main.c ${CMAKE_CURRENT_SOURCE_DIR}/board_desc.c
      DEPS firmware)
    target_include_directories(${name} PRIVATE ${PROJECT_SOURCE_DIR}/boards/cortex-m ${stm32})
    target_compile_definitions(${name} PRIVATE BOARD_IRQ_COUNT=${irqs} BOARD_NAME="${board}"
                                                  BOARD_UART_IRQ=${ARG_UART_IRQ})
    if(variant)
      string(TOUPPER ${variant} def)
      target_compile_definitions(${name} PRIVATE TWIN_TEST_${def}=1)
    endif()
    target_link_options(${name} PRIVATE -L${PROJECT_SOURCE_DIR}/boards/cortex-m)
  endforeach()
  # The flight image's flash and RAM by part, and its stack margin (tools/image_budget.py).
  # Link-time optimised: the parts from the ELF's debug information (the map names only the
  # link's partitions).
  set(budget_elf "")
  if(TOF_LTO)
    string(REGEX REPLACE "nm$" "" tools_prefix "${CMAKE_NM}")
    set(budget_elf --elf $<TARGET_FILE:${image}> --tools ${tools_prefix})
  endif()
  add_custom_target(budget
    COMMAND /usr/bin/python3 ${PROJECT_SOURCE_DIR}/tools/image_budget.py
            $<TARGET_FILE_DIR:${image}>/${image}.map ${budget_elf}
            --stack $<TARGET_FILE_DIR:${image}>/${image}.stack.json ${TOF_BUDGET_ARGS}
    DEPENDS ${image}
    COMMENT "Flash, RAM and stack of ${image} by part" VERBATIM)
  add_custom_target(flash
    COMMAND sh -c "command -v openocd >/dev/null || { echo 'flash: openocd missing: run tools/setup.sh' >&2; exit 1; }"
    COMMAND openocd -f ${openocd_cfg} -c "program $<TARGET_FILE:${image}> verify reset exit"
    DEPENDS ${image}
    COMMENT "Flashing ${board} over ST-LINK with openocd" VERBATIM)
endfunction()
