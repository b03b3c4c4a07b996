/* The simulated GPIO controller, whose pins wire to device models (sim/sim_gpio.h). */
#include "sim/sim_gpio.h"

#include <stddef.h>

#include "hal/hal_err.h"

void sim_gpio_init(struct sim_gpio *gpio) {
    for (size_t i = 0; i < SIM_GPIO_PINS; ++i) {
        gpio->pins[i].drive = NULL;
        gpio->pins[i].sample = NULL;
        gpio->pins[i].ctx = NULL;
        gpio->pins[i].level = false;
    }
    gpio->writes = 0u;
    gpio->reads = 0u;
}

int sim_gpio_wire(struct sim_gpio *gpio, uint16_t pin, void (*drive)(void *ctx, bool high),
                  bool (*sample)(void *ctx), void *ctx) {
    if (pin >= SIM_GPIO_PINS) {
        return -1;
    }
    gpio->pins[pin].drive = drive;
    gpio->pins[pin].sample = sample;
    gpio->pins[pin].ctx = ctx;
    return 0;
}

static int sim_gpio_write(void *ctx, uint16_t pin, bool high) {
    struct sim_gpio *gpio = ctx;
    if (pin >= SIM_GPIO_PINS) {
        return HAL_ERR_INVALID;
    }
    gpio->writes++;
    struct sim_gpio_pin *p = &gpio->pins[pin];
    p->level = high;
    if (p->drive != NULL) {
        p->drive(p->ctx, high);
    }
    return HAL_OK;
}

static int sim_gpio_read(void *ctx, uint16_t pin, bool *high) {
    struct sim_gpio *gpio = ctx;
    if (pin >= SIM_GPIO_PINS || high == NULL) {
        return HAL_ERR_INVALID;
    }
    gpio->reads++;
    const struct sim_gpio_pin *p = &gpio->pins[pin];
    *high = p->sample != NULL ? p->sample(p->ctx) : p->level;
    return HAL_OK;
}

const struct hal_gpio_ops sim_gpio_hal_ops = {
    .write = sim_gpio_write,
    .read = sim_gpio_read,
};

struct hal_gpio sim_gpio_hal(struct sim_gpio *gpio) {
    struct hal_gpio handle = {&sim_gpio_hal_ops, gpio};
    return handle;
}
