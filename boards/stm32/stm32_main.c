/*
 * main() of the STM32 NUCLEO boards (BOARD_NAME from the build): the board HAL
 * (clocks, SysTick time, I²C1 at 400 kHz, sensor GPIOs, USART2, watchdog), the
 * application, and the telemetry link on USART2 (ST-LINK virtual COM port).
 * The boot banner and fault messages go to the same port as text before and
 * outside telemetry frames; the frame decoder skips them (docs/reference/telemetry-protocol.md).
 */
#include <stddef.h>

#include "board.h"
#include "board_hal.h"
#include "firmware/app.h"
#include "firmware/calibration_record.h"
#include "firmware/config.h"
#include "firmware/link.h"
#include "firmware/link_storage.h"
#include "firmware/record.h"
#include "firmware/text.h"
#include "stm32_usart.h"

/* State is static, so its size shows in the map file rather than on the stack. */
static struct tof_app app;
static struct tof_link link;
static struct tof_platform platform;
static struct tof_record_store records; /* the saved settings (firmware/settings.h) */
static struct tof_cal_age cal_age;      /* the calibration's age (firmware/cal_age.h) */

#if defined(TWIN_TEST_HANG) || defined(TWIN_TEST_BAD_SEQUENCE) || defined(TWIN_TEST_STACK_OVERFLOW)
#define TWIN_TEST 1
#include "stm32_board.h"
#include "stm32_i2c_regs.h"
#include "stm32_reg.h"
/* Test builds for the twin (tests/twin), never the flight image: the flight ELF is built
 * without any of these. Kept across the watchdog reset so the hang happens once. */
__attribute__((section(".noinit"))) static volatile uint32_t twin_test_boots;
#define TWIN_TEST_MAGIC 0x7E57B007u
#endif

int main(void) {
    const int rc = board_hal_init();
    if (rc != 0) {
        board_fault("board_hal_init failed");
    }
#if defined(TWIN_TEST_BAD_SEQUENCE)
    /* Deliberately wrong: TIMINGR may only be written with PE = 0 (RM0351 §39.7.5). */
    stm32_reg_write(stm32_board_desc.i2c_base + STM32_I2C_TIMINGR,
                    STM32_I2C_TIMINGR_400KHZ_AT_16MHZ);
#endif
#if defined(TWIN_TEST_STACK_OVERFLOW)
    /* Push words until far past the bottom of the stack: must fault, not corrupt .bss. */
    uint32_t words = 4096u;
    __asm__ volatile("1: push {r0}\n subs %0, %0, #1\n bne 1b" : "+r"(words)::"memory", "cc");
#endif
    tof_link_init(&link, board_hal_serial());
    /* storage pages 0, 1: the calibration's age; 2, 3: the record (board_desc.c) */
    const struct hal_records storage = board_hal_records();
    /* A board without storage (ops NULL, a constant of its board_desc.c) names none of the
     * storage code here, so its image links none (firmware/link_storage.h). */
    if (storage.ops != NULL && tof_record_init(&records, storage, 2u, 3u) == 0) {
        tof_link_set_records(&link, &tof_link_storage,
                             &records); /* none: defaults, `save` refused */
        if (tof_cal_age_init(&cal_age, storage, 0u, 1u) == 0) {
            /* the stored calibration's age, its pages read before the application's timeline
             * starts (the link's start hands it to the estimator); none: from each boot */
            (void)tof_record_load(&records);
            const uint16_t tag = tof_cal_tag(&records);
            const struct hal_time t = board_hal_time();
            (void)tof_cal_age_boot(&cal_age, tag != 0u, tag,
                                   tof_app_default_config.cal_off_allowance_s,
                                   t.ops->now_us(t.ctx));
            tof_link_set_cal_age(&link, &cal_age);
        }
    }
    platform = (struct tof_platform){
        .board_name = BOARD_NAME,
        .i2c = board_hal_i2c(),
        .gpio = board_hal_gpio(),
        .time = board_hal_time(),
        .log = board_hal_log(),
        .watchdog = board_hal_watchdog(),
        .temp = board_hal_temp(),
        .output = {.ops = &tof_link_output_ops, .ctx = &link},
        .xshut_pin = {BOARD_HAL_XSHUT_PIN(0), BOARD_HAL_XSHUT_PIN(1), BOARD_HAL_XSHUT_PIN(2),
                      BOARD_HAL_XSHUT_PIN(3)},
        .gpio1_pin = {BOARD_HAL_GPIO1_PIN(0), BOARD_HAL_GPIO1_PIN(1), BOARD_HAL_GPIO1_PIN(2),
                      BOARD_HAL_GPIO1_PIN(3)},
        .sensor_pads_at_avdd =
            true, /* the NUCLEO boards' 3V3 pull-ups (docs/explanation/driver-and-bus.md) */
    };
    const struct tof_app_service telemetry = {.ops = &tof_link_service_ops, .ctx = &link};
#if defined(TWIN_TEST_HANG)
    if (twin_test_boots != TWIN_TEST_MAGIC) {
        /* First boot: run 300 iterations (the estimators are running), then hang without
         * kicking the watchdog; after its reset the firmware must come back and run. */
        twin_test_boots = TWIN_TEST_MAGIC;
        (void)tof_app_main(&platform, &tof_app_default_config, &app, &telemetry, 300u);
        while (twin_test_boots == TWIN_TEST_MAGIC) {
        }
    }
#endif
    return tof_app_main(&platform, &tof_app_default_config, &app, &telemetry, 0);
}

void board_exit(int status) {
    (void)status;
    cortex_m_system_reset(); /* an MCU has nowhere to return to */
}

void board_fault(const char *what) {
    static const char prefix[] = "FAULT: ";
    board_hal_fault_write(prefix, sizeof prefix - 1u);
    size_t n = 0;
    while (n < 64u && what[n] != '\0') {
        ++n;
    }
    board_hal_fault_write(what, n);
    const uint32_t vector = cortex_m_fault_vector;
    if (vector != 0u && vector < 512u) {
        /* " (vector N)": which exception, so an IRQ without a handler can be named. */
        char num[16];
        struct tof_text t;
        tof_text_init(&t, num, sizeof num);
        tof_text_str(&t, " (vector ");
        tof_text_u64(&t, vector);
        tof_text_str(&t, ")");
        board_hal_fault_write(num, t.len);
        cortex_m_fault_vector = 0u;
    }
    board_hal_fault_write("\n", 1u);
    board_hal_fault_flush(); /* the reset would cut off the last bytes (seen in the twin) */
    cortex_m_system_reset(); /* the watchdog would do it too, later */
}
