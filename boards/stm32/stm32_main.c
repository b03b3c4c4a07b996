/*
 * main() of the STM32 NUCLEO boards (BOARD_NAME from the build): the board HAL
 * (clocks, SysTick time, I²C1 at 400 kHz, sensor GPIOs, USART2, watchdog), the
 * application, and the telemetry link on USART2 (ST-LINK virtual COM port).
 * The boot banner and fault messages go to the same port as text before and
 * outside telemetry frames; the frame decoder skips them (docs/telemetry.md).
 */
#include <stddef.h>

#include "board.h"
#include "board_hal.h"
#include "firmware/app.h"
#include "firmware/link.h"
#include "stm32_usart.h"

/* State is static, so its size shows in the map file rather than on the stack. */
static struct tof_app app;
static struct tof_link link;
static struct tof_platform platform;

int main(void) {
    const int rc = board_hal_init();
    if (rc != 0) {
        board_fault("board_hal_init failed");
    }
    tof_link_init(&link, board_hal_serial());
    platform = (struct tof_platform){
        .board_name = BOARD_NAME,
        .i2c = board_hal_i2c(),
        .gpio = board_hal_gpio(),
        .time = board_hal_time(),
        .log = board_hal_log(),
        .watchdog = board_hal_watchdog(),
        .output = {.ops = &tof_link_output_ops, .ctx = &link},
        .xshut_pin = {BOARD_HAL_XSHUT_PIN(0), BOARD_HAL_XSHUT_PIN(1), BOARD_HAL_XSHUT_PIN(2),
                      BOARD_HAL_XSHUT_PIN(3)},
        .gpio1_pin = {BOARD_HAL_GPIO1_PIN(0), BOARD_HAL_GPIO1_PIN(1), BOARD_HAL_GPIO1_PIN(2),
                      BOARD_HAL_GPIO1_PIN(3)},
        .sensor_pads_at_avdd = true, /* the NUCLEO boards' 3V3 pull-ups (docs/driver.md) */
    };
    const struct tof_app_service telemetry = {.ops = &tof_link_service_ops, .ctx = &link};
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
    board_hal_fault_write("\n", 1u);
    cortex_m_system_reset(); /* the watchdog would do it too, later */
}
