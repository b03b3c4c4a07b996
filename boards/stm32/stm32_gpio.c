/* STM32 GPIO pin helpers and the hal_gpio implementation on them (stm32_gpio.h). */
#include "stm32_gpio.h"

#include "hal/hal_err.h"
#include "stm32_gpio_regs.h"
#include "stm32_reg.h"

void stm32_gpio_set_mode(uintptr_t port, uint8_t pin, uint32_t mode) {
    const uint32_t shift = 2u * pin;
    stm32_reg_modify(port + STM32_GPIO_MODER, 3u << shift, (mode & 3u) << shift);
}

void stm32_gpio_set_af(uintptr_t port, uint8_t pin, uint32_t af) {
    const uintptr_t reg = port + (pin < 8u ? STM32_GPIO_AFRL : STM32_GPIO_AFRH);
    const uint32_t shift = 4u * (pin & 7u);
    stm32_reg_modify(reg, 0xFu << shift, (af & 0xFu) << shift);
}

void stm32_gpio_set_open_drain(uintptr_t port, uint8_t pin, bool open_drain) {
    stm32_reg_modify(port + STM32_GPIO_OTYPER, 1u << pin, open_drain ? (1u << pin) : 0u);
}

void stm32_gpio_set_pull(uintptr_t port, uint8_t pin, uint32_t pull) {
    const uint32_t shift = 2u * pin;
    stm32_reg_modify(port + STM32_GPIO_PUPDR, 3u << shift, (pull & 3u) << shift);
}

void stm32_gpio_write_pin(uintptr_t port, uint8_t pin, bool high) {
    /* BSRR: bit n sets ODRn, bit n+16 resets it, in one bus write (RM0351 §8.5 "GPIO port bit
     * set/reset register"). */
    stm32_reg_write(port + STM32_GPIO_BSRR, high ? (1u << pin) : (1u << (pin + 16u)));
}

bool stm32_gpio_read_pin(uintptr_t port, uint8_t pin) {
    return (stm32_reg_read(port + STM32_GPIO_IDR) & (1u << pin)) != 0u;
}

int stm32_gpio_configure(const struct stm32_gpio *gpio) {
    if (gpio == NULL || (gpio->pins == NULL && gpio->count != 0u)) {
        return HAL_ERR_INVALID;
    }
    for (uint16_t i = 0; i < gpio->count; ++i) {
        const struct stm32_pin *p = &gpio->pins[i];
        if (p->pin > 15u) {
            return HAL_ERR_INVALID;
        }
        switch (p->role) {
        case STM32_PIN_OUTPUT_OPEN_DRAIN:
            /* Low first, then open-drain output: the sensor stays in shutdown
             * until the firmware releases XSHUT. The breakout's pull-up (and
             * the weak internal one) makes "released" a defined high. */
            stm32_gpio_write_pin(p->port, p->pin, false);
            stm32_gpio_set_open_drain(p->port, p->pin, true);
            stm32_gpio_set_pull(p->port, p->pin, STM32_GPIO_PULL_UP);
            stm32_gpio_set_mode(p->port, p->pin, STM32_GPIO_MODE_OUTPUT);
            break;
        case STM32_PIN_INPUT_PULL_UP:
            stm32_gpio_set_pull(p->port, p->pin, STM32_GPIO_PULL_UP);
            stm32_gpio_set_mode(p->port, p->pin, STM32_GPIO_MODE_INPUT);
            break;
        default:
            return HAL_ERR_INVALID;
        }
    }
    return HAL_OK;
}

int stm32_gpio_hal_write(void *ctx, uint16_t pin, bool high) {
    const struct stm32_gpio *gpio = ctx;
    if (gpio == NULL || pin >= gpio->count || gpio->pins[pin].role != STM32_PIN_OUTPUT_OPEN_DRAIN) {
        return HAL_ERR_INVALID;
    }
    stm32_gpio_write_pin(gpio->pins[pin].port, gpio->pins[pin].pin, high);
    return HAL_OK;
}

int stm32_gpio_hal_read(void *ctx, uint16_t pin, bool *high) {
    const struct stm32_gpio *gpio = ctx;
    if (gpio == NULL || high == NULL || pin >= gpio->count) {
        return HAL_ERR_INVALID;
    }
    *high = stm32_gpio_read_pin(gpio->pins[pin].port, gpio->pins[pin].pin);
    return HAL_OK;
}

const struct hal_gpio_ops stm32_gpio_hal_ops = {
    .write = stm32_gpio_hal_write,
    .read = stm32_gpio_hal_read,
};
