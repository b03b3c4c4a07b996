/*
 * Simulated GPIO controller: a hal_gpio implementation whose pins can be wired to
 * device models: an output drives a device input (XSHUT), an input samples a device
 * output (GPIO1 interrupt). Unwired pins keep the level last written and read it back.
 */
#ifndef SIM_GPIO_H
#define SIM_GPIO_H

#include <stdbool.h>
#include <stdint.h>

#include "hal/hal_gpio.h"

#define SIM_GPIO_PINS 16u

struct sim_gpio_pin {
    /* Output side: called with the new level when the MCU writes the pin (may be NULL). */
    void (*drive)(void *ctx, bool high);
    /* Input side: the level a device puts on the pin now (NULL: the last written level). */
    bool (*sample)(void *ctx);
    void *ctx;
    bool level; /* last level written by the MCU */
};

struct sim_gpio {
    struct sim_gpio_pin pins[SIM_GPIO_PINS];
    uint32_t writes;
    uint32_t reads;
};

/* All pins unwired, low. */
void sim_gpio_init(struct sim_gpio *gpio);

/* Wire `pin` as an output into a device (drive) and/or an input from it (sample).
 * 0, or -1 for a pin out of range. The pin's level is left as it is. */
int sim_gpio_wire(struct sim_gpio *gpio, uint16_t pin, void (*drive)(void *ctx, bool high),
                  bool (*sample)(void *ctx), void *ctx);

/* hal_gpio over a sim_gpio: ctx is the struct sim_gpio *. HAL_ERR_INVALID for pins out of range. */
extern const struct hal_gpio_ops sim_gpio_hal_ops;

/* A hal_gpio handle for `gpio`. */
struct hal_gpio sim_gpio_hal(struct sim_gpio *gpio);

#endif /* SIM_GPIO_H */
