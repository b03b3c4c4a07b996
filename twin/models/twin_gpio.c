/* GPIO ports A..H of the twin (RM0351 §8) and the NUCLEO-L476RG's wiring to the sensor
 * head: XSHUT lines into the VL53 models, their GPIO1 lines and the I2C1 lines back. */
#include "twin.h"
#include "twin_world.h"

#define GPIO_MODER   0x00u
#define GPIO_OTYPER  0x04u
#define GPIO_OSPEEDR 0x08u
#define GPIO_PUPDR   0x0Cu
#define GPIO_IDR     0x10u
#define GPIO_ODR     0x14u
#define GPIO_BSRR    0x18u
#define GPIO_LCKR    0x1Cu
#define GPIO_AFRL    0x20u
#define GPIO_AFRH    0x24u
#define GPIO_BRR     0x28u
#define GPIO_ASCR    0x2Cu

#define MODE_INPUT  0u
#define MODE_OUTPUT 1u
#define MODE_AF     2u
#define MODE_ANALOG 3u

enum role { NONE, XSHUT, GPIO1, I2C_SCL, I2C_SDA };

/* The harness (docs/explanation/boards.md pin map; UM1724 Arduino connector): port, pin -> role. */
struct wire {
    unsigned port, pin;
    enum role role;
    unsigned sensor;
};
static const struct wire wires[] = {
    {0, 10, XSHUT, 0}, {1, 3, XSHUT, 1}, {1, 5, XSHUT, 2}, {1, 4, XSHUT, 3},   {1, 10, GPIO1, 0},
    {0, 8, GPIO1, 1},  {0, 9, GPIO1, 2}, {2, 7, GPIO1, 3}, {1, 8, I2C_SCL, 0}, {1, 9, I2C_SDA, 0},
};
#define WIRES (sizeof wires / sizeof wires[0])

/* Last XSHUT level given to each model, and the recovery clock count. */
static bool xshut_level[4] = {true, true, true, true};
static unsigned scl_edges;
static bool scl_last = true;

static const struct wire *wire_of(unsigned port, unsigned pin) {
    for (unsigned i = 0; i < WIRES; ++i) {
        if (wires[i].port == port && wires[i].pin == pin) {
            return &wires[i];
        }
    }
    return NULL;
}

uint32_t twin_gpio_mode(const struct twin *t, unsigned port, unsigned pin) {
    return (t->gpio[port].moder >> (2u * pin)) & 3u;
}

uint32_t twin_gpio_af(const struct twin *t, unsigned port, unsigned pin) {
    const struct twin_gpio *g = &t->gpio[port];
    return pin < 8u ? (g->afrl >> (4u * pin)) & 0xFu : (g->afrh >> (4u * (pin - 8u))) & 0xFu;
}

/* Does the MCU pull the pin low itself (output driving 0, or I2C1 in AF 4 holding it)? */
static bool mcu_drives_low(const struct twin *t, unsigned port, unsigned pin) {
    const uint32_t mode = twin_gpio_mode(t, port, pin);
    if (mode == MODE_OUTPUT) {
        return (t->gpio[port].odr & (1u << pin)) == 0u;
    }
    return false;
}

static bool mcu_drives_high(const struct twin *t, unsigned port, unsigned pin) {
    const struct twin_gpio *g = &t->gpio[port];
    return twin_gpio_mode(t, port, pin) == MODE_OUTPUT && (g->otyper & (1u << pin)) == 0u &&
           (g->odr & (1u << pin)) != 0u;
}

/* The level on the line: the breakout boards pull XSHUT, GPIO1, SCL and SDA up
 * (docs/explanation/boards.md), so a released line reads high unless a device pulls it down. */
static bool line_level(struct twin *t, unsigned port, unsigned pin) {
    const struct wire *w = wire_of(port, pin);
    if (mcu_drives_low(t, port, pin)) {
        return false;
    }
    if (w == NULL) {
        if (mcu_drives_high(t, port, pin)) {
            return true;
        }
        /* Unconnected: the internal pull (PUPDR, RM0351 §8.4.4) decides; floating reads 0. */
        return ((t->gpio[port].pupdr >> (2u * pin)) & 3u) == 1u;
    }
    switch (w->role) {
    case GPIO1:
        return t->world != NULL ? twin_world_gpio1(t->world, w->sensor) : true;
    case I2C_SDA:
        return t->world == NULL || !twin_world_sda_stuck(t->world);
    default:
        return true;
    }
}

static void update_outputs(struct twin *t) {
    if (t->world == NULL) {
        return;
    }
    twin_world_sync(t->world, twin_svc_now_us(&t->svc));
    for (unsigned i = 0; i < WIRES; ++i) {
        const struct wire *w = &wires[i];
        if (w->role == XSHUT) {
            const bool level = !mcu_drives_low(t, w->port, w->pin);
            if (level != xshut_level[w->sensor]) {
                xshut_level[w->sensor] = level;
                twin_world_xshut(t->world, w->sensor, level);
            }
        } else if (w->role == I2C_SCL) {
            /* Bus recovery (UM10204 §3.1.16): SCL clocked as a GPIO output releases a device
             * holding SDA. */
            const bool scl = !mcu_drives_low(t, w->port, w->pin);
            if (twin_gpio_mode(t, w->port, w->pin) == MODE_OUTPUT) {
                if (scl && !scl_last) {
                    ++scl_edges;
                    if (twin_world_sda_stuck(t->world)) {
                        twin_world_recover(t->world);
                    }
                }
            } else {
                scl_edges = 0;
            }
            scl_last = scl;
        }
    }
}

void twin_gpio_reset(struct twin *t) {
    /* Reset values: RM0351 §8.5 (MODER: port A 0xABFFFFFF, port B 0xFFFFFEBF, others all
     * analog; OSPEEDR A 0x0C000000; PUPDR A 0x64000000, B 0x00000100: the debug pins). */
    for (unsigned p = 0; p < TWIN_GPIO_PORTS; ++p) {
        t->gpio[p] = (struct twin_gpio){.moder = 0xFFFFFFFFu};
    }
    t->gpio[0].moder = 0xABFFFFFFu;
    t->gpio[0].ospeedr = 0x0C000000u;
    t->gpio[0].pupdr = 0x64000000u;
    t->gpio[1].moder = 0xFFFFFEBFu;
    t->gpio[1].pupdr = 0x00000100u;
    scl_edges = 0;
    scl_last = true;
    update_outputs(t);
}

static uint32_t idr(struct twin *t, unsigned port) {
    uint32_t v = 0;
    for (unsigned pin = 0; pin < 16u; ++pin) {
        /* Analog mode disables the input Schmitt trigger: IDR reads 0 (RM0351 §8.4.12). */
        if (twin_gpio_mode(t, port, pin) != MODE_ANALOG && line_level(t, port, pin)) {
            v |= 1u << pin;
        }
    }
    return v;
}

uint32_t twin_gpio_read(struct twin *t, unsigned port, uint32_t off) {
    struct twin_gpio *g = &t->gpio[port];
    switch (off) {
    case GPIO_MODER:
        return g->moder;
    case GPIO_OTYPER:
        return g->otyper;
    case GPIO_OSPEEDR:
        return g->ospeedr;
    case GPIO_PUPDR:
        return g->pupdr;
    case GPIO_IDR:
        if (t->world != NULL) {
            twin_world_sync(t->world, twin_svc_now_us(&t->svc));
        }
        return idr(t, port);
    case GPIO_ODR:
        return g->odr;
    case GPIO_BSRR:
    case GPIO_BRR:
        return 0u; /* write-only */
    case GPIO_LCKR:
        return g->lckr;
    case GPIO_AFRL:
        return g->afrl;
    case GPIO_AFRH:
        return g->afrh;
    case GPIO_ASCR:
        return g->ascr;
    default:
        twin_svc_violation(&t->svc, "GPIO register", off, "reserved GPIO offset (RM0351 §8.5.13)");
        return 0u;
    }
}

static void check_af(struct twin *t, unsigned port) {
    /* Alternate functions the harness uses (DS10198 Table 17): I2C1 on PB8/PB9 is AF4,
     * USART2 on PA2/PA3 is AF7. A pin of the harness in AF mode with any other function
     * is a wiring error on the real board. */
    for (unsigned pin = 0; pin < 16u; ++pin) {
        if (twin_gpio_mode(t, port, pin) != MODE_AF) {
            continue;
        }
        const uint32_t af = twin_gpio_af(t, port, pin);
        const struct wire *w = wire_of(port, pin);
        const bool i2c = w != NULL && (w->role == I2C_SCL || w->role == I2C_SDA);
        const bool uart = port == 0u && (pin == 2u || pin == 3u);
        if (!i2c && !uart && af == 0u) {
            continue; /* AF0, the debug port's reset function (SWD, JTAG) */
        }
        if ((i2c && af != 4u) || (uart && af != 7u) || (!i2c && !uart)) {
            char reg[32];
            snprintf(reg, sizeof reg, "GPIO%c MODER pin %u", 'A' + port, pin);
            twin_svc_violation(&t->svc, reg, af,
                               "pin in alternate-function mode with a function the board does not "
                               "wire there (DS10198 Table 17)");
        }
        if (i2c && (t->gpio[port].otyper & (1u << pin)) == 0u) {
            twin_svc_violation(&t->svc, "GPIOB OTYPER", t->gpio[port].otyper,
                               "I2C pin in push-pull mode: I2C lines must be open-drain (RM0351 "
                               "§39.3)");
        }
    }
}

void twin_gpio_write(struct twin *t, unsigned port, uint32_t off, uint32_t v) {
    struct twin_gpio *g = &t->gpio[port];
    switch (off) {
    case GPIO_MODER:
        g->moder = v;
        check_af(t, port);
        break;
    case GPIO_OTYPER:
        g->otyper = v & 0xFFFFu;
        break;
    case GPIO_OSPEEDR:
        g->ospeedr = v;
        break;
    case GPIO_PUPDR:
        g->pupdr = v;
        break;
    case GPIO_ODR:
        g->odr = v & 0xFFFFu;
        break;
    case GPIO_BSRR:
        /* RM0351 §8.4.7: bits 0-15 set, bits 16-31 reset; set wins when both are given. */
        g->odr = (g->odr & ~(v >> 16)) | (v & 0xFFFFu);
        break;
    case GPIO_BRR:
        g->odr &= ~(v & 0xFFFFu);
        break;
    case GPIO_LCKR:
        g->lckr = v;
        break;
    case GPIO_AFRL:
        g->afrl = v;
        break;
    case GPIO_AFRH:
        g->afrh = v;
        break;
    case GPIO_ASCR:
        g->ascr = v;
        break;
    case GPIO_IDR:
        twin_svc_violation(&t->svc, "GPIO IDR", v, "IDR is read-only (RM0351 §8.5.5)");
        break;
    default:
        twin_svc_violation(&t->svc, "GPIO register", off, "reserved GPIO offset (RM0351 §8.5.13)");
        break;
    }
    update_outputs(t);
}
