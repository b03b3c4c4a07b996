/*
 * GPIO on STM32 ports (L4 and G0 share the register layout): single-pin
 * helpers used by the board code and the I2C bus recovery, and a hal_gpio
 * implementation that maps the firmware's numbered pins 0..count-1 to
 * port/pin pairs through a const per-board table.
 */
#ifndef BOARDS_STM32_GPIO_H
#define BOARDS_STM32_GPIO_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "hal/hal_gpio.h"

/* How a numbered pin is used. */
enum stm32_pin_role {
    STM32_PIN_OUTPUT_OPEN_DRAIN, /* XSHUT: driven low or released; starts low (sensor off) */
    STM32_PIN_INPUT_PULL_UP,     /* GPIO1: the sensor's open-drain data-ready output */
};

/* One numbered pin: its port, pin number on that port and role. */
struct stm32_pin {
    uintptr_t port; /* GPIOx base address */
    uint8_t pin;    /* 0..15 */
    uint8_t role;   /* enum stm32_pin_role */
};

/* The hal_gpio context: a const pin table (the firmware's pin N is pins[N]). */
struct stm32_gpio {
    const struct stm32_pin *pins;
    uint16_t count;
};

/* Set pin `pin` of `port` to MODER mode (STM32_GPIO_MODE_*). */
void stm32_gpio_set_mode(uintptr_t port, uint8_t pin, uint32_t mode);

/* Select alternate function `af` (0..15) for `pin` (takes effect in AF mode). */
void stm32_gpio_set_af(uintptr_t port, uint8_t pin, uint32_t af);

/* Output type of `pin`: open-drain (true) or push-pull. */
void stm32_gpio_set_open_drain(uintptr_t port, uint8_t pin, bool open_drain);

/* Pull resistor of `pin` (STM32_GPIO_PULL_*). */
void stm32_gpio_set_pull(uintptr_t port, uint8_t pin, uint32_t pull);

/* Drive `pin` high or low through BSRR (atomic; no read-modify-write of ODR). */
void stm32_gpio_write_pin(uintptr_t port, uint8_t pin, bool high);

/* Level of `pin` as seen by the input stage (IDR), in any mode. */
bool stm32_gpio_read_pin(uintptr_t port, uint8_t pin);

/*
 * Configure every pin of `gpio` for its role: outputs are set low before they
 * become outputs (no glitch high), inputs get the pull-up. The caller has
 * enabled the port clocks. HAL_OK, or HAL_ERR_INVALID for a pin > 15 or an
 * unknown role (nothing after it is configured).
 */
int stm32_gpio_configure(const struct stm32_gpio *gpio);

/* hal_gpio write: HAL_ERR_INVALID for an unknown pin or one that is not an output. */
int stm32_gpio_hal_write(void *ctx, uint16_t pin, bool high);

/* hal_gpio read (the IDR level of any numbered pin): HAL_ERR_INVALID for an unknown pin. */
int stm32_gpio_hal_read(void *ctx, uint16_t pin, bool *high);

extern const struct hal_gpio_ops stm32_gpio_hal_ops;

#endif /* BOARDS_STM32_GPIO_H */
