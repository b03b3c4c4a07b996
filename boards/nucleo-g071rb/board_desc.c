/*
 * NUCLEO-G071RB board description for the shared STM32 board HAL
 * (boards/stm32/stm32_board.c): pins, addresses, alternate functions and clocks
 * (docs/explanation/boards.md has the pin map, clock choice, I2C timing and watchdog figures).
 *
 * Clock: SYSCLK = HSISYS = HSI16 / 1 = 16 MHz, the reset configuration
 * (RM0444 §5.2), made explicit here; flash stays at 0 wait states (RM0444 "Embedded
 * flash memory", "Read access latency" table: 0 WS up to 24 MHz). Same core clock, SysTick
 * reload, USART BRR and I2C TIMINGR as the L476 board; I2C1 takes HSI16 as
 * its kernel clock.
 */
#include "hal/hal_err.h"
#include "stm32_board.h"
#include "stm32_reg.h"
#include "stm32g071_regs.h"
#include "board_hal.h"
#include "stm32_adc_g0_regs.h"
#include "stm32_adc_temp.h"

/* Numbered pins (board_hal.h): Arduino D2..D9 of the NUCLEO-G071RB (UM2324
 * "Arduino connectors"; same mapping in Zephyr
 * boards/arm/nucleo_g071rb/arduino_r3_connector.dtsi). D6 is PB14 on this
 * board (PB10 on the L476). SWD (PA13/PA14) is untouched. */
static const struct stm32_pin sensor_pins[2u * BOARD_HAL_SENSOR_COUNT] = {
    {G071_GPIOA_BASE, 10u, STM32_PIN_OUTPUT_OPEN_DRAIN}, /* 0: XSHUT A, D2 */
    {G071_GPIOB_BASE, 3u, STM32_PIN_OUTPUT_OPEN_DRAIN},  /* 1: XSHUT B, D3 */
    {G071_GPIOB_BASE, 5u, STM32_PIN_OUTPUT_OPEN_DRAIN},  /* 2: XSHUT C, D4 */
    {G071_GPIOB_BASE, 4u, STM32_PIN_OUTPUT_OPEN_DRAIN},  /* 3: XSHUT D, D5 */
    {G071_GPIOB_BASE, 14u, STM32_PIN_INPUT_PULL_UP},     /* 4: GPIO1 A, D6 */
    {G071_GPIOA_BASE, 8u, STM32_PIN_INPUT_PULL_UP},      /* 5: GPIO1 B, D7 */
    {G071_GPIOA_BASE, 9u, STM32_PIN_INPUT_PULL_UP},      /* 6: GPIO1 C, D8 */
    {G071_GPIOC_BASE, 7u, STM32_PIN_INPUT_PULL_UP},      /* 7: GPIO1 D, D9 */
};

const struct stm32_board_desc stm32_board_desc = {
    .sensor_pins = sensor_pins,
    /* I2C1 on D15 = PB8 (SCL) and D14 = PB9 (SDA), 400 kHz. */
    .i2c_base = G071_I2C1_BASE,
    .i2c_scl = {G071_GPIOB_BASE, 8u, G071_AF6_I2C1_PB8_PB9},
    .i2c_sda = {G071_GPIOB_BASE, 9u, G071_AF6_I2C1_PB8_PB9},
    /* USART2 on PA2 (TX) and PA3 (RX), the same alternate function for both
     * (datasheet alternate-function table): the ST-LINK virtual COM port. */
    .usart_base = G071_USART2_BASE,
    .usart_port = G071_GPIOA_BASE,
    .usart_tx_pin = 2u,
    .usart_rx_pin = 3u,
    .usart_af = G071_AF1_USART2_TX_PA2,
    .iwdg_base = G071_IWDG_BASE,
    .dbg_freeze_reg = G071_DBG_APB_FZ1,
    .dbg_freeze_bit = G071_DBG_APB_FZ1_DBG_IWDG_STOP,
};

/* SYSCLK = HSISYS with HSIDIV = /1: the reset state, asserted so that a
 * bootloader or debugger that changed it cannot leave the timing wrong. */
int stm32_board_clock_init(void) {
    stm32_reg_modify(G071_RCC_CR, G071_RCC_CR_HSIDIV_MASK, G071_RCC_CR_HSION);
    if (!stm32_board_poll_bits(G071_RCC_CR, G071_RCC_CR_HSIRDY, G071_RCC_CR_HSIRDY,
                               STM32_BOARD_CLOCK_READY_POLLS)) {
        return HAL_ERR_TIMEOUT;
    }
    stm32_reg_modify(G071_RCC_CFGR, G071_RCC_CFGR_SW_MASK, 0u);
    if (!stm32_board_poll_bits(G071_RCC_CFGR, G071_RCC_CFGR_SWS_MASK, 0u,
                               STM32_BOARD_CLOCK_READY_POLLS)) {
        return HAL_ERR_TIMEOUT;
    }
    return HAL_OK;
}

/* SYSCLK is HSISYS = HSI16 / HSIDIV from reset (RM0444 §5.2 "Clocks": HSIDIV resets to /1)
 * and after stm32_board_clock_init: 16 MHz either way. */
uint32_t stm32_board_sysclk_hz(void) {
    return 16000000u;
}

void stm32_board_peripheral_clocks_init(void) {
    stm32_reg_modify(G071_RCC_IOPENR, 0u,
                     G071_RCC_IOPENR_GPIOAEN | G071_RCC_IOPENR_GPIOBEN | G071_RCC_IOPENR_GPIOCEN);
    stm32_reg_modify(G071_RCC_CCIPR, G071_RCC_CCIPR_I2C1SEL_MASK, G071_RCC_CCIPR_I2C1SEL_HSI16);
    stm32_reg_modify(G071_RCC_APBENR2, 0u, G071_RCC_APBENR2_ADCEN);
    stm32_reg_modify(G071_RCC_APBENR1, 0u,
                     G071_RCC_APBENR1_USART2EN | G071_RCC_APBENR1_I2C1EN | G071_RCC_APBENR1_DBGEN);
    (void)stm32_reg_read(G071_RCC_APBENR1); /* read back: the enables have taken effect */
}

/* No record storage on this board yet: the STM32G0's flash interface differs from the L4's in
 * its page numbering and busy flags (RM0444 §3), and no driver for it has been written and
 * tested. The firmware runs on defaults and refuses `save` (docs/explanation/boards.md "Records").
 */
struct hal_records stm32_board_records(struct hal_time time) {
    (void)time;
    const struct hal_records none = {.ops = NULL, .ctx = NULL, .geometry = {0}};
    return none;
}

/* The MCU's own temperature sensor (stm32_adc_temp.h, the G0 half). ADC clock PCLK/2 = 8 MHz;
 * SMP1 160.5 ADC clocks = 20 us against the datasheet's 5 us (sensor) and 4 us (VREFINT)
 * (DS12232 "Temperature sensor characteristics" tS_temp, "Embedded internal voltage
 * reference" tS_vrefint); the regulator's tADCVREG_STUP 20 us (DS12232 "ADC
 * characteristics") and 120 us for the sensor and VREFINT buffers, as on the L476. */
static struct stm32_adc_temp_config temp_config;
static struct stm32_adc_temp temp_adc;

struct hal_temp stm32_board_temp(struct hal_time time) {
    temp_config = (struct stm32_adc_temp_config){
        .adc_base = G071_ADC_BASE,
        .common_base = G071_ADC_COMMON_BASE,
        .ts_cal1_addr = G071_TS_CAL1_ADDR,
        .ts_cal2_addr = G071_TS_CAL2_ADDR,
        .vrefint_cal_addr = G071_VREFINT_CAL_ADDR,
        .ts_cal1_cdeg = G071_TS_CAL1_CDEG,
        .ts_cal2_cdeg = G071_TS_CAL2_CDEG,
        .ts_channel = G071_ADC_CH_TEMPSENSOR,
        .vrefint_channel = G071_ADC_CH_VREFINT,
        .smp_code = STM32_ADC_G0_SMP_160_5,
        .regulator_startup_us = 20u,
        .sensor_startup_us = 120u,
        .poll_budget_us = 1000u,
        .time = time,
    };
    stm32_adc_temp_init(&temp_adc, &temp_config);
    const struct hal_temp temp = {.ops = &stm32_adc_g0_temp_ops, .ctx = &temp_adc};
    return temp;
}
