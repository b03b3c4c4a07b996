/*
 * NUCLEO-L476RG board description for the shared STM32 board HAL
 * (boards/stm32/stm32_board.c): pins, addresses, alternate functions and clocks
 * (docs/explanation/boards.md has the pin map, clock choice, I2C timing and watchdog figures).
 *
 * Clock: SYSCLK = 64 MHz from the main PLL fed by HSI16 (AHB and APB prescalers left
 * at /1), 3 flash wait states: a window's end at N = 255 takes 220k-370k instructions
 * depending on the data, which at 16 MHz made the worst loop 19.5 ms against a 20 ms
 * period, and 11.7 ms at 32 MHz on a held-out trace (docs/explanation/boards.md "Clock tree").
 * I2C1 takes HSI16 directly as its kernel clock, so its timing does not depend on SYSCLK;
 * SysTick and the USART divisor follow the clock the RCC reports (stm32_board_sysclk_hz).
 */
#include "hal/hal_err.h"
#include "stm32_board.h"
#include "stm32_reg.h"
#include "stm32l476_regs.h"
#include "board_hal.h"
#include "stm32_adc_temp.h"
#include "stm32_flash.h"
#include "stm32_adc_regs.h"
#include "stm32_flash_regs.h"

/* Numbered pins (board_hal.h): Arduino D2..D9 of UM1724 "Arduino connectors"
 * (same mapping in Zephyr boards/arm/nucleo_l476rg/arduino_r3_connector.dtsi).
 * PB3/PB4 leave their reset JTDO/NJTRST function; SWD (PA13/PA14) is untouched. */
static const struct stm32_pin sensor_pins[2u * BOARD_HAL_SENSOR_COUNT] = {
    {L476_GPIOA_BASE, 10u, STM32_PIN_OUTPUT_OPEN_DRAIN}, /* 0: XSHUT A, D2 */
    {L476_GPIOB_BASE, 3u, STM32_PIN_OUTPUT_OPEN_DRAIN},  /* 1: XSHUT B, D3 */
    {L476_GPIOB_BASE, 5u, STM32_PIN_OUTPUT_OPEN_DRAIN},  /* 2: XSHUT C, D4 */
    {L476_GPIOB_BASE, 4u, STM32_PIN_OUTPUT_OPEN_DRAIN},  /* 3: XSHUT D, D5 */
    {L476_GPIOB_BASE, 10u, STM32_PIN_INPUT_PULL_UP},     /* 4: GPIO1 A, D6 */
    {L476_GPIOA_BASE, 8u, STM32_PIN_INPUT_PULL_UP},      /* 5: GPIO1 B, D7 */
    {L476_GPIOA_BASE, 9u, STM32_PIN_INPUT_PULL_UP},      /* 6: GPIO1 C, D8 */
    {L476_GPIOC_BASE, 7u, STM32_PIN_INPUT_PULL_UP},      /* 7: GPIO1 D, D9 */
};

const struct stm32_board_desc stm32_board_desc = {
    .sensor_pins = sensor_pins,
    /* I2C1 on D15 = PB8 (SCL) and D14 = PB9 (SDA), 400 kHz. */
    .i2c_base = L476_I2C1_BASE,
    .i2c_scl = {L476_GPIOB_BASE, 8u, L476_AF4_I2C1_PB8_PB9},
    .i2c_sda = {L476_GPIOB_BASE, 9u, L476_AF4_I2C1_PB8_PB9},
    /* USART2 on PA2 (TX) and PA3 (RX), the same alternate function for both
     * (datasheet alternate-function table): the ST-LINK virtual COM port. */
    .usart_base = L476_USART2_BASE,
    .usart_port = L476_GPIOA_BASE,
    .usart_tx_pin = 2u,
    .usart_rx_pin = 3u,
    .usart_af = L476_AF7_USART2_TX_PA2,
    .iwdg_base = L476_IWDG_BASE,
    .dbg_freeze_reg = L476_DBGMCU_APB1FZR1,
    .dbg_freeze_bit = L476_DBGMCU_APB1FZR1_DBG_IWDG_STOP,
};

/* SYSCLK = HSI16 / M x N / R from the main PLL (RM0351 §6.2.5 "PLL"): 16 MHz / 1 x 8 / 2 =
 * 64 MHz, the VCO at 128 MHz (input 4..16 MHz, VCO 64..344 MHz: RM0351 §6.4.4). Why 64 MHz
 * (the worst loop against the power): docs/explanation/boards.md "Clock tree". */
#define L476_PLL_N      8u
#define L476_PLL_R_DIV  2u
#define L476_PLL_R_BITS ((L476_PLL_R_DIV / 2u - 1u) << L476_RCC_PLLCFGR_PLLR_SHIFT)
#define L476_SYSCLK_HZ  (16000000u * L476_PLL_N / L476_PLL_R_DIV)
/* RM0351 §3.3.3 Table 12, voltage range 1 (the reset range): one wait state per 16 MHz
 * above the first 16 (3 WS up to 64 MHz). */
#define L476_FLASH_LATENCY ((L476_SYSCLK_HZ - 1u) / 16000000u)

/* SYSCLK from MSI 4 MHz (reset) to the PLL fed by HSI16. The order is the reference
 * manual's: the flash wait states raised and read back before the clock rises (RM0351
 * §3.3.3 "Increasing the CPU frequency"); the PLL configured while it is off (it is after
 * any reset), then PLLON, PLLRDY, PLLREN (§6.2.5); then the switch, confirmed by SWS
 * (§6.2.6). The AHB/APB prescalers stay /1: PCLK1 = SYSCLK clocks USART2. */
int stm32_board_clock_init(void) {
    stm32_reg_modify(L476_RCC_CR, 0u, L476_RCC_CR_HSION);
    if (!stm32_board_poll_bits(L476_RCC_CR, L476_RCC_CR_HSIRDY, L476_RCC_CR_HSIRDY,
                               STM32_BOARD_CLOCK_READY_POLLS)) {
        return HAL_ERR_TIMEOUT;
    }
    stm32_reg_modify(L476_FLASH_ACR, L476_FLASH_ACR_LATENCY_MASK, L476_FLASH_LATENCY);
    if (!stm32_board_poll_bits(L476_FLASH_ACR, L476_FLASH_ACR_LATENCY_MASK, L476_FLASH_LATENCY,
                               STM32_BOARD_CLOCK_READY_POLLS)) {
        return HAL_ERR_TIMEOUT;
    }
    stm32_reg_write(L476_RCC_PLLCFGR, L476_RCC_PLLCFGR_PLLSRC_HSI16 |
                                          (L476_PLL_N << L476_RCC_PLLCFGR_PLLN_SHIFT) |
                                          L476_PLL_R_BITS); /* PLLM = 0: / 1 */
    stm32_reg_modify(L476_RCC_CR, 0u, L476_RCC_CR_PLLON);
    if (!stm32_board_poll_bits(L476_RCC_CR, L476_RCC_CR_PLLRDY, L476_RCC_CR_PLLRDY,
                               STM32_BOARD_CLOCK_READY_POLLS)) {
        return HAL_ERR_TIMEOUT;
    }
    stm32_reg_modify(L476_RCC_PLLCFGR, 0u, L476_RCC_PLLCFGR_PLLREN);
    stm32_reg_modify(L476_RCC_CFGR, L476_RCC_CFGR_SW_MASK, L476_RCC_CFGR_SW_PLL);
    if (!stm32_board_poll_bits(L476_RCC_CFGR, L476_RCC_CFGR_SWS_MASK, L476_RCC_CFGR_SWS_PLL,
                               STM32_BOARD_CLOCK_READY_POLLS)) {
        return HAL_ERR_TIMEOUT;
    }
    return HAL_OK;
}

/* RCC_CFGR.SWS: 11 = the PLL, 01 = HSI16; anything else here is the reset clock, MSI range
 * 6 = 4 MHz (RM0351 §6.2.3 "MSI clock": 4 MHz after reset; the firmware never changes the
 * range). */
uint32_t stm32_board_sysclk_hz(void) {
    const uint32_t sws = stm32_reg_read(L476_RCC_CFGR) & L476_RCC_CFGR_SWS_MASK;
    return sws == L476_RCC_CFGR_SWS_PLL     ? L476_SYSCLK_HZ
           : sws == L476_RCC_CFGR_SWS_HSI16 ? 16000000u
                                            : 4000000u;
}

void stm32_board_peripheral_clocks_init(void) {
    stm32_reg_modify(L476_RCC_AHB2ENR, 0u,
                     L476_RCC_AHB2ENR_GPIOAEN | L476_RCC_AHB2ENR_GPIOBEN |
                         L476_RCC_AHB2ENR_GPIOCEN | L476_RCC_AHB2ENR_ADCEN);
    stm32_reg_modify(L476_RCC_CCIPR, L476_RCC_CCIPR_I2C1SEL_MASK, L476_RCC_CCIPR_I2C1SEL_HSI16);
    stm32_reg_modify(L476_RCC_APB1ENR1, 0u, L476_RCC_APB1ENR1_USART2EN | L476_RCC_APB1ENR1_I2C1EN);
    (void)stm32_reg_read(L476_RCC_APB1ENR1); /* read back: the enables have taken effect */
}

/* The storage pages: the last 8 KB of the 1 MB flash, which the linker script keeps out of
 * the FLASH region (stm32l476rg.ld, __records_start): bank 2 (0x0808 0000 up, RM0351
 * §3.3.1 "Flash memory organization"), pages 252..255: the calibration's age on 252 and 253
 * (storage pages 0, 1: firmware/cal_age.h), the record on 254 and 255 (storage pages 2, 3:
 * firmware/record.h, where it has always been). The image runs from bank 1, so
 * erasing them does not stall the core (§3.3.8 read-while-write). Busy bounds from the
 * datasheet (DS10198 "Flash memory characteristics": page erase <= 24.47 ms, one
 * double-word <= 90.76 us), with margin. */
extern const uint8_t __records_start[];
#define L476_FLASH_BASE  0x08000000u
#define L476_BANK2_START 0x08080000u

static struct stm32_flash_config records_config;
static struct stm32_flash records_flash;

struct hal_records stm32_board_records(struct hal_time time) {
    const uintptr_t at = (uintptr_t)__records_start;
    const uint32_t page = (uint32_t)(at - L476_FLASH_BASE) / STM32_FLASH_PAGE_SIZE;
    records_config = (struct stm32_flash_config){
        .regs = STM32L4_FLASH_REGS,
        .memory = at,
        .first_page = (uint16_t)(page % STM32_FLASH_BANK_PAGES),
        .pages = 4u,
        .bank2 = at >= L476_BANK2_START,
        .erase_budget_us = 40000u,
        .program_budget_us = 1000u,
        .time = time,
    };
    if (stm32_flash_init(&records_flash, &records_config) != HAL_OK) {
        const struct hal_records none = {.ops = NULL, .ctx = NULL, .geometry = {0}};
        return none;
    }
    return stm32_flash_hal(&records_flash);
}

/* The MCU's own temperature sensor on ADC1 (stm32_adc_temp.h). Sampling time 640.5 ADC clocks:
 * 20 us at HCLK/2 = 32 MHz, 160 us at the 4 MHz reset clock, against the datasheet's minimum of
 * 5 us for the sensor and 4 us for VREFINT (DS10198 "Temperature sensor characteristics",
 * tS_temp; "Embedded internal voltage reference", tS_vrefint). Start-up waits: the
 * regulator's tADCVREG_STUP (20 us, DS10198 "ADC characteristics") and 120 us for the sensor and
 * VREFINT buffers (tSTART / tstart_vrefint, above the datasheet's maxima). A flag poll may take
 * 1 ms: a conversion takes 41 us at 32 MHz, the calibration 116 ADC clocks. */
static struct stm32_adc_temp_config temp_config;
static struct stm32_adc_temp temp_adc;

struct hal_temp stm32_board_temp(struct hal_time time) {
    temp_config = (struct stm32_adc_temp_config){
        .adc_base = L476_ADC1_BASE,
        .common_base = L476_ADC_COMMON_BASE,
        .ts_cal1_addr = L476_TS_CAL1_ADDR,
        .ts_cal2_addr = L476_TS_CAL2_ADDR,
        .vrefint_cal_addr = L476_VREFINT_CAL_ADDR,
        .ts_cal1_cdeg = L476_TS_CAL1_CDEG,
        .ts_cal2_cdeg = L476_TS_CAL2_CDEG,
        .ts_channel = L476_ADC_CH_TEMPSENSOR,
        .vrefint_channel = L476_ADC_CH_VREFINT,
        .smp_code = STM32_ADC_SMP_640_5,
        .regulator_startup_us = 20u,
        .sensor_startup_us = 120u,
        .poll_budget_us = 1000u,
        .time = time,
    };
    stm32_adc_temp_init(&temp_adc, &temp_config);
    const struct hal_temp temp = {.ops = &stm32_adc_temp_ops, .ctx = &temp_adc};
    return temp;
}

void NMI_Handler(void);
void Default_Handler(void);

/* A read of a torn double-word raises an NMI (ECC double error, RM0351 §3.3.2): the flash
 * driver takes it and its read reports HAL_ERR_CORRUPT; any other NMI is a fault. */
void NMI_Handler(void) {
    if (!stm32_flash_nmi(STM32L4_FLASH_REGS)) {
        Default_Handler();
    }
}
