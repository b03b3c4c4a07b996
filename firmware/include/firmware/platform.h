/*
 * What a board hands the application: its HAL implementations. The firmware
 * is linked unchanged into every target (MCU boards, QEMU, host_sim); only the
 * platform differs. A board leaves an interface's ops NULL when it has none.
 */
#ifndef FIRMWARE_PLATFORM_H
#define FIRMWARE_PLATFORM_H

#include "hal/hal_gpio.h"
#include "hal/hal_i2c.h"
#include "hal/hal_log.h"
#include "hal/hal_time.h"

struct tof_platform {
    const char *board_name; /* e.g. "nucleo-l476rg", "mps2-an386", "host_sim" */
    struct hal_i2c i2c;
    struct hal_gpio gpio;
    struct hal_time time;
    struct hal_log log;
};

#endif /* FIRMWARE_PLATFORM_H */
