/*
 * Polled I2Cv2 master. Transfer sequences follow "I2C master mode" in RM0351
 * §39.4 (RM0444 §32.4): CR2 carries the address, direction, NBYTES and
 * START; TXIS asks for each byte to send, RXNE delivers each byte received;
 * more than 255 bytes use RELOAD/TCR; with AUTOEND = 0 the end of the write
 * phase is TC, after which a new START in CR2 is the repeated start.
 */
#include "stm32_i2c.h"

#include <stdbool.h>

#include "hal/hal_err.h"
#include "stm32_gpio.h"
#include "stm32_gpio_regs.h"
#include "stm32_i2c_regs.h"
#include "stm32_reg.h"

/* Flags that end a wait with a failure, whatever the wait was for. BERR is not one: errata
 * sheet ES0250 (STM32L476xx/486xx device errata), I2C "Spurious bus error detection in master
 * mode": in master mode BERR can be set with no effect on the transfer, which continues
 * normally; the workaround is to clear the flag and do nothing else. A real misplaced
 * START/STOP in master mode shows as ARLO or as a flag that never comes (the budget). */
#define FAIL_FLAGS (STM32_I2C_ISR_NACKF | STM32_I2C_ISR_ARLO)

/* UM10204 §3.1.16: nine clocks are enough for a slave to finish any byte it is sending. */
#define RECOVERY_CLOCKS 9u
/* Longest a slave may stretch SCL during recovery before the bus is declared stuck. */
#define RECOVERY_STRETCH_LIMIT_US 1000u
/* PE must read back 0 before it is set again (RM0351 §39.4 "Software reset"). */
#define SOFTWARE_RESET_READS 8u

/* Time and poll budget of one operation. */
struct budget {
    const struct hal_time *time;
    uint32_t start_us;
    uint32_t limit_us;
    /* Backstop if the time source stops: a poll costs at least one core cycle,
     * so limit_us x cycles-per-us polls never run out before limit_us does. */
    uint32_t polls_left;
};

enum wait_result { WAIT_DONE, WAIT_FAILED, WAIT_TIMED_OUT };

static uint32_t sat_add(uint32_t a, uint32_t b) {
    return a > UINT32_MAX - b ? UINT32_MAX : a + b;
}

static uint32_t sat_mul(uint32_t a, uint32_t b) {
    if (a != 0u && b > UINT32_MAX / a) {
        return UINT32_MAX;
    }
    return a * b;
}

static uint32_t clamp_u32(size_t n) {
    return n > (size_t)UINT32_MAX ? UINT32_MAX : (uint32_t)n;
}

static void budget_start(struct budget *b, const struct stm32_i2c_config *cfg, uint32_t limit_us) {
    b->time = &cfg->time;
    b->start_us = cfg->time.ops->now_us(cfg->time.ctx);
    b->limit_us = limit_us;
    b->polls_left = sat_add(sat_mul(limit_us, cfg->core_cycles_per_us), 1u);
}

/* True once the budget is spent (time or polls); each call uses one poll. */
static bool budget_spent(struct budget *b) {
    if (b->polls_left == 0u) {
        return true;
    }
    b->polls_left--;
    const uint32_t now = b->time->ops->now_us(b->time->ctx);
    return hal_time_elapsed_us(now, b->start_us) > b->limit_us;
}

static uint32_t reg(const struct stm32_i2c_config *cfg, uint32_t offset) {
    return stm32_reg_read(cfg->base + offset);
}

static void set_reg(const struct stm32_i2c_config *cfg, uint32_t offset, uint32_t value) {
    stm32_reg_write(cfg->base + offset, value);
}

/* Poll ISR until a `want` flag or a FAIL_FLAGS flag is set, or the budget is spent. A BERR
 * is cleared, counted and otherwise ignored (ES0250, see FAIL_FLAGS). */
static enum wait_result wait_isr(struct stm32_i2c *bus, struct budget *b, uint32_t want,
                                 uint32_t *isr_out) {
    const struct stm32_i2c_config *cfg = bus->cfg;
    do { /* bounded: each budget_spent() call uses one of a finite number of polls */
        const uint32_t isr = reg(cfg, STM32_I2C_ISR);
        *isr_out = isr;
        if ((isr & STM32_I2C_ISR_BERR) != 0u) {
            set_reg(cfg, STM32_I2C_ICR, STM32_I2C_ICR_BERRCF);
            bus->stats.bus_errors++;
        }
        if ((isr & FAIL_FLAGS) != 0u) {
            return WAIT_FAILED;
        }
        if ((isr & want) != 0u) {
            return WAIT_DONE;
        }
    } while (!budget_spent(b));
    return WAIT_TIMED_OUT;
}

/* Software reset (RM0351 §39.4 "Software reset"): PE = 0, read back until 0, PE = 1. Clears
 * BUSY, the transfer flags and the internal state machines; TIMINGR is kept. */
static void software_reset(const struct stm32_i2c_config *cfg) {
    set_reg(cfg, STM32_I2C_CR1, reg(cfg, STM32_I2C_CR1) & ~STM32_I2C_CR1_PE);
    for (uint32_t i = 0; i < SOFTWARE_RESET_READS; ++i) {
        if ((reg(cfg, STM32_I2C_CR1) & STM32_I2C_CR1_PE) == 0u) {
            break;
        }
    }
    set_reg(cfg, STM32_I2C_CR1, reg(cfg, STM32_I2C_CR1) | STM32_I2C_CR1_PE);
}

/* CR2 for the next chunk of `remaining` bytes (no START bit). */
static uint32_t cr2_chunk(uint8_t addr7, bool read, size_t remaining, bool stop_at_end) {
    const uint32_t nbytes =
        remaining > STM32_I2C_NBYTES_MAX ? STM32_I2C_NBYTES_MAX : (uint32_t)remaining;
    uint32_t cr2 = ((uint32_t)addr7 << 1) | (nbytes << STM32_I2C_CR2_NBYTES_SHIFT);
    if (read) {
        cr2 |= STM32_I2C_CR2_RD_WRN;
    }
    if (remaining > STM32_I2C_NBYTES_MAX) {
        cr2 |= STM32_I2C_CR2_RELOAD;
    } else if (stop_at_end) {
        cr2 |= STM32_I2C_CR2_AUTOEND;
    }
    return cr2;
}

/* Map a failed wait to the hal error and count it. A NACK is an address NACK
 * when no data byte has been asked for yet: TXIS (and RXNE) only appear after
 * the address was acknowledged (RM0351 §39.4 "I2C master mode", master transmitter sequence). */
static int failure(struct stm32_i2c *bus, enum wait_result w, uint32_t isr, bool address_phase) {
    if (w == WAIT_TIMED_OUT) {
        bus->stats.timeouts++;
        return HAL_ERR_TIMEOUT;
    }
    if ((isr & STM32_I2C_ISR_ARLO) != 0u) {
        bus->stats.arbitration_lost++;
        return HAL_ERR_BUS_BUSY;
    }
    if (address_phase) {
        bus->stats.addr_nacks++;
        return HAL_ERR_ADDR_NACK;
    }
    bus->stats.data_nacks++;
    return HAL_ERR_DATA_NACK;
}

/*
 * One direction of a transfer: START (or repeated START) with the address,
 * then `len` bytes, then either STOP (AUTOEND, `stop_at_end`) or TC, which
 * leaves the bus held for the repeated start of the read phase.
 */
static int run_phase(struct stm32_i2c *bus, struct budget *b, uint8_t addr7, bool read,
                     const uint8_t *tx, uint8_t *rx, size_t len, bool stop_at_end) {
    const struct stm32_i2c_config *cfg = bus->cfg;
    const uint32_t data_flag = read ? STM32_I2C_ISR_RXNE : STM32_I2C_ISR_TXIS;
    uint32_t isr = 0u;
    enum wait_result w;

    set_reg(cfg, STM32_I2C_CR2, cr2_chunk(addr7, read, len, stop_at_end) | STM32_I2C_CR2_START);
    size_t chunk_left = len > STM32_I2C_NBYTES_MAX ? STM32_I2C_NBYTES_MAX : len;
    for (size_t done = 0; done < len;) {
        w = wait_isr(bus, b, data_flag, &isr);
        if (w != WAIT_DONE) {
            /* Reading: the slave cannot NACK data (the master acknowledges), so
             * a NACK is always on the address. */
            return failure(bus, w, isr, read || done == 0u);
        }
        if (read) {
            rx[done] = (uint8_t)(reg(cfg, STM32_I2C_RXDR) & 0xFFu);
        } else {
            set_reg(cfg, STM32_I2C_TXDR, tx[done]);
        }
        ++done;
        --chunk_left;
        if (chunk_left == 0u && done < len) {
            /* Chunk of 255 done with RELOAD: TCR, then the next NBYTES. */
            w = wait_isr(bus, b, STM32_I2C_ISR_TCR, &isr);
            if (w != WAIT_DONE) {
                return failure(bus, w, isr, read);
            }
            const size_t remaining = len - done;
            chunk_left = remaining > STM32_I2C_NBYTES_MAX ? STM32_I2C_NBYTES_MAX : remaining;
            set_reg(cfg, STM32_I2C_CR2, cr2_chunk(addr7, read, remaining, stop_at_end));
        }
    }
    w = wait_isr(bus, b, stop_at_end ? STM32_I2C_ISR_STOPF : STM32_I2C_ISR_TC, &isr);
    if (w != WAIT_DONE) {
        return failure(bus, w, isr, read); /* writing: the last byte was NACKed */
    }
    if (stop_at_end) {
        set_reg(cfg, STM32_I2C_ICR, STM32_I2C_ICR_STOPCF);
    }
    return HAL_OK;
}

/*
 * Leave the peripheral idle after a failure. After a NACK the master sends
 * STOP by itself (RM0351 §39.4 "I2C master mode": "a STOP condition is automatically sent after the
 * NACK reception"): wait for it within two byte times. After arbitration loss, a bus error, a
 * timeout or a missing STOP the peripheral is software-reset, which also flushes TXDR.
 */
static void clean_up(struct stm32_i2c *bus, int err) {
    const struct stm32_i2c_config *cfg = bus->cfg;
    bool reset = true;
    if (err == HAL_ERR_ADDR_NACK || err == HAL_ERR_DATA_NACK) {
        struct budget b;
        budget_start(&b, cfg, sat_add(sat_mul(2u, cfg->byte_time_us), 1u));
        do { /* bounded by the budget */
            if ((reg(cfg, STM32_I2C_ISR) & STM32_I2C_ISR_STOPF) != 0u) {
                reset = false;
                break;
            }
        } while (!budget_spent(&b));
    }
    set_reg(cfg, STM32_I2C_ICR, STM32_I2C_ICR_ALL);
    /* TXIS asks for the next byte while the current one is still being shifted
     * out, so after a NACK TXDR may hold a byte that was never sent; writing
     * TXE = 1 flushes it (I2C_ISR "TXE" bit description) so the next transfer
     * cannot start with it. */
    set_reg(cfg, STM32_I2C_ISR, STM32_I2C_ISR_TXE);
    if (reset) {
        software_reset(cfg);
    }
}

int stm32_i2c_write_read(void *ctx, uint8_t addr7, const uint8_t *tx, size_t tx_len, uint8_t *rx,
                         size_t rx_len, uint32_t timeout_us) {
    struct stm32_i2c *bus = ctx;
    if (bus == NULL || bus->cfg == NULL || addr7 > 0x7Fu || (tx_len == 0u && rx_len == 0u) ||
        (tx_len > 0u && tx == NULL) || (rx_len > 0u && rx == NULL)) {
        return HAL_ERR_INVALID;
    }
    const struct stm32_i2c_config *cfg = bus->cfg;

    /* Bus state before START: BUSY means a START was seen without its STOP
     * (another master, or a transfer cut short); a line held low with the bus
     * idle is a slave stuck mid-byte, which only recovery can clear. */
    if ((reg(cfg, STM32_I2C_ISR) & STM32_I2C_ISR_BUSY) != 0u) {
        bus->stats.busy++;
        return HAL_ERR_BUS_BUSY;
    }
    if (!stm32_gpio_read_pin(cfg->sda.port, cfg->sda.pin) ||
        !stm32_gpio_read_pin(cfg->scl.port, cfg->scl.pin)) {
        bus->stats.stuck++;
        return HAL_ERR_BUS_STUCK;
    }

    /* The caller's budget covers waiting; the bytes themselves (data plus the
     * two address bytes) take byte_time_us each at the configured speed. */
    const uint32_t bytes = sat_add(sat_add(clamp_u32(tx_len), clamp_u32(rx_len)), 2u);
    struct budget b;
    budget_start(&b, cfg, sat_add(timeout_us, sat_mul(bytes, cfg->byte_time_us)));
    bus->stats.transfers++;
    set_reg(cfg, STM32_I2C_ICR, STM32_I2C_ICR_ALL);

    int err = HAL_OK;
    if (tx_len > 0u) {
        err = run_phase(bus, &b, addr7, false, tx, NULL, tx_len, rx_len == 0u);
    }
    if (err == HAL_OK && rx_len > 0u) {
        err = run_phase(bus, &b, addr7, true, NULL, rx, rx_len, true);
    }
    if (err != HAL_OK) {
        clean_up(bus, err);
    }
    return err;
}

/* Release SCL and wait (bounded) until it reads high: a slave may stretch it. */
static bool release_scl(const struct stm32_i2c_config *cfg) {
    stm32_gpio_write_pin(cfg->scl.port, cfg->scl.pin, true);
    struct budget b;
    budget_start(&b, cfg, RECOVERY_STRETCH_LIMIT_US);
    do { /* bounded by the budget */
        if (stm32_gpio_read_pin(cfg->scl.port, cfg->scl.pin)) {
            return true;
        }
    } while (!budget_spent(&b));
    return false;
}

static void pins_to_alternate_function(const struct stm32_i2c_config *cfg) {
    stm32_gpio_set_af(cfg->scl.port, cfg->scl.pin, cfg->scl.af);
    stm32_gpio_set_af(cfg->sda.port, cfg->sda.pin, cfg->sda.af);
    stm32_gpio_set_mode(cfg->scl.port, cfg->scl.pin, STM32_GPIO_MODE_AF);
    stm32_gpio_set_mode(cfg->sda.port, cfg->sda.pin, STM32_GPIO_MODE_AF);
}

int stm32_i2c_recover(void *ctx) {
    struct stm32_i2c *bus = ctx;
    if (bus == NULL || bus->cfg == NULL) {
        return HAL_ERR_INVALID;
    }
    const struct stm32_i2c_config *cfg = bus->cfg;
    const struct hal_time *time = &cfg->time;
    const uint32_t half = cfg->recovery_half_period_us;
    bus->stats.recoveries++;

    /* The peripheral must not drive the lines while they are bit-banged. */
    set_reg(cfg, STM32_I2C_CR1, reg(cfg, STM32_I2C_CR1) & ~STM32_I2C_CR1_PE);
    /* Released (ODR high) before they become open-drain GPIO outputs. */
    stm32_gpio_write_pin(cfg->scl.port, cfg->scl.pin, true);
    stm32_gpio_write_pin(cfg->sda.port, cfg->sda.pin, true);
    stm32_gpio_set_open_drain(cfg->scl.port, cfg->scl.pin, true);
    stm32_gpio_set_open_drain(cfg->sda.port, cfg->sda.pin, true);
    stm32_gpio_set_mode(cfg->scl.port, cfg->scl.pin, STM32_GPIO_MODE_OUTPUT);
    stm32_gpio_set_mode(cfg->sda.port, cfg->sda.pin, STM32_GPIO_MODE_OUTPUT);
    time->ops->delay_us(time->ctx, half);

    /* Up to nine clocks with SDA released, stopping as soon as the slave lets
     * SDA go (the same rule as Linux i2c_generic_scl_recovery). */
    bool scl_free = release_scl(cfg);
    for (uint32_t i = 0; scl_free && i < RECOVERY_CLOCKS; ++i) {
        if (stm32_gpio_read_pin(cfg->sda.port, cfg->sda.pin)) {
            break;
        }
        stm32_gpio_write_pin(cfg->scl.port, cfg->scl.pin, false);
        time->ops->delay_us(time->ctx, half);
        scl_free = release_scl(cfg);
        time->ops->delay_us(time->ctx, half);
    }

    /* STOP: SDA low while SCL is low, SCL high, then SDA rises with SCL high. */
    if (scl_free) {
        stm32_gpio_write_pin(cfg->scl.port, cfg->scl.pin, false);
        time->ops->delay_us(time->ctx, half);
        stm32_gpio_write_pin(cfg->sda.port, cfg->sda.pin, false);
        time->ops->delay_us(time->ctx, half);
        scl_free = release_scl(cfg);
        time->ops->delay_us(time->ctx, half);
        stm32_gpio_write_pin(cfg->sda.port, cfg->sda.pin, true);
        time->ops->delay_us(time->ctx, half);
    }
    const bool lines_high = scl_free && stm32_gpio_read_pin(cfg->sda.port, cfg->sda.pin) &&
                            stm32_gpio_read_pin(cfg->scl.port, cfg->scl.pin);

    pins_to_alternate_function(cfg);
    set_reg(cfg, STM32_I2C_ICR, STM32_I2C_ICR_ALL);
    set_reg(cfg, STM32_I2C_CR1, reg(cfg, STM32_I2C_CR1) | STM32_I2C_CR1_PE);
    if (!lines_high) {
        bus->stats.recoveries_failed++;
        return HAL_ERR_BUS_STUCK;
    }
    return HAL_OK;
}

int stm32_i2c_init(struct stm32_i2c *bus, const struct stm32_i2c_config *cfg) {
    if (bus == NULL || cfg == NULL || cfg->time.ops == NULL || cfg->time.ops->now_us == NULL ||
        cfg->time.ops->delay_us == NULL || cfg->timingr == 0u || cfg->byte_time_us == 0u ||
        cfg->core_cycles_per_us == 0u || cfg->recovery_half_period_us == 0u || cfg->scl.pin > 15u ||
        cfg->sda.pin > 15u || cfg->scl.af > 15u || cfg->sda.af > 15u) {
        return HAL_ERR_INVALID;
    }
    bus->cfg = cfg;
    bus->stats = (struct stm32_i2c_stats){0};

    /* TIMINGR may only be written with PE = 0 (RM0351 §39.4 "I2C timings", caution). */
    set_reg(cfg, STM32_I2C_CR1, 0u);
    /* Open-drain with pull-ups (RM0351 §39.4 "I2C pins and internal signals": open-drain); the
     * internal ~40 kOhm pull-ups only keep an unconnected bus defined, 400 kHz
     * needs the external 2.2-4.7 kOhm pull-ups of the sensor boards. */
    const struct stm32_i2c_pin *pins[2] = {&cfg->scl, &cfg->sda};
    for (unsigned i = 0; i < 2u; ++i) {
        stm32_gpio_write_pin(pins[i]->port, pins[i]->pin, true);
        stm32_gpio_set_open_drain(pins[i]->port, pins[i]->pin, true);
        stm32_gpio_set_pull(pins[i]->port, pins[i]->pin, STM32_GPIO_PULL_UP);
    }
    pins_to_alternate_function(cfg);
    set_reg(cfg, STM32_I2C_TIMINGR, cfg->timingr);
    set_reg(cfg, STM32_I2C_ICR, STM32_I2C_ICR_ALL);
    set_reg(cfg, STM32_I2C_CR1, STM32_I2C_CR1_PE);
    return HAL_OK;
}

const struct hal_i2c_ops stm32_i2c_hal_ops = {
    .write_read = stm32_i2c_write_read,
    .recover = stm32_i2c_recover,
};

struct hal_i2c stm32_i2c_hal(struct stm32_i2c *bus) {
    struct hal_i2c i2c = {&stm32_i2c_hal_ops, bus};
    return i2c;
}
