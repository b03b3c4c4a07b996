/*
 * GPIO interface: numbered pins of one controller behind an ops struct.
 * The firmware maps sensors to pins in its const configuration (XSHUT outputs,
 * GPIO1 data-ready inputs); nothing here knows about sensors.
 */
#ifndef HAL_GPIO_H
#define HAL_GPIO_H

#include <stdbool.h>
#include <stdint.h>

struct hal_gpio_ops {
    /* Drive output `pin` high (true) or low. HAL_OK or HAL_ERR_INVALID for an unknown pin. */
    int (*write)(void *ctx, uint16_t pin, bool high);
    /* Read input `pin` into *high. HAL_OK or HAL_ERR_INVALID. */
    int (*read)(void *ctx, uint16_t pin, bool *high);
};

struct hal_gpio {
    const struct hal_gpio_ops *ops;
    void *ctx;
};

#endif /* HAL_GPIO_H */
