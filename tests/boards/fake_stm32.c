/* Register-level fakes of the STM32 peripherals for the board drivers' host tests. */
#include "fake_stm32.h"
#include "fake_stm32_adc.h"
#include "fake_stm32_flash.h"

#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include <cmocka.h>

#include "cortex_m_regs.h"
#include "stm32_gpio_regs.h"
#include "stm32_i2c_regs.h"
#include "stm32_iwdg_regs.h"
#include "stm32_reg.h"

struct fake_stm32 fake;

enum { I2C_CR1 = 0, I2C_CR2 = 1, I2C_TIMINGR = 4, I2C_ISR = 6, I2C_ICR = 7, I2C_RXDR = 9 };
enum { I2C_TXDR = 10 };
enum { GPIO_MODER = 0, GPIO_IDR = 4, GPIO_ODR = 5, GPIO_BSRR = 6, GPIO_BRR = 10 };
enum { SCL_PIN = 8, SDA_PIN = 9 };

/* Flags a PE = 0 software reset clears (RM0351 §39.4 "Software reset"). */
#define RESET_CLEARS                                                                               \
    (STM32_I2C_ISR_TXIS | STM32_I2C_ISR_RXNE | STM32_I2C_ISR_NACKF | STM32_I2C_ISR_STOPF |         \
     STM32_I2C_ISR_TC | STM32_I2C_ISR_TCR | STM32_I2C_ISR_BERR | STM32_I2C_ISR_ARLO |              \
     STM32_I2C_ISR_OVR | STM32_I2C_ISR_BUSY)

/* ------------------------------------------------------------------ time */

static uint32_t fake_now_us(void *ctx) {
    struct fake_time *t = ctx;
    const uint32_t now = t->now;
    t->now += t->step_us;
    t->calls++;
    return now;
}

static void fake_delay_us(void *ctx, uint32_t us) {
    struct fake_time *t = ctx;
    t->now += us;
}

static const struct hal_time_ops fake_time_ops = {fake_now_us, fake_delay_us};

struct hal_time fake_time_hal(void) {
    struct hal_time time = {&fake_time_ops, &fake.time};
    return time;
}

/* ------------------------------------------------------------------ setup */

void fake_reset(int present_addr, uint32_t start_us) {
    memset(&fake, 0, sizeof fake);
    fake.i2c.regs[I2C_ISR] = STM32_I2C_ISR_TXE; /* ISR reset value */
    fake.i2c.script.present_addr = present_addr;
    fake.i2c.script.nack_byte = FAKE_NONE;
    fake.i2c.script.stall_after_bytes = FAKE_NONE;
    for (size_t i = 0; i < FAKE_RX_MAX; ++i) {
        fake.i2c.script.rx_data[i] = (uint8_t)(0xA0u + i);
    }
    fake.lines.last_scl = true;
    fake.lines.last_sda = true;
    fake.time.now = start_us;
    fake.time.step_us = 1u;
    fake.systick.cvr_default = 0u;
}

void fake_set_sda_stuck(uint32_t clocks) {
    fake.lines.sda_release_after_clocks = clocks;
    fake.lines.last_sda = clocks == 0u;
}

void fake_set_scl_stuck(void) {
    fake.lines.scl_held_low = true;
    fake.lines.last_scl = false;
}

uintptr_t fake_i2c_base(void) {
    return (uintptr_t)fake.i2c.regs;
}

static struct fake_gpio_port *port_of(char port) {
    switch (port) {
    case 'A':
        return &fake.port_a;
    case 'B':
        return &fake.port_b;
    case 'C':
        return &fake.port_c;
    default:
        fail_msg("no fake GPIO port %c", port);
        return &fake.port_a; /* not reached: fail_msg ends the test (keeps -O3 from warning) */
    }
}

uintptr_t fake_port_base(char port) {
    return (uintptr_t)port_of(port)->regs;
}

uintptr_t fake_iwdg_base(void) {
    return (uintptr_t)fake.iwdg.regs;
}

uint32_t fake_i2c_reg(uint32_t offset) {
    return fake.i2c.regs[offset / 4u];
}

uint32_t fake_port_reg(char port, uint32_t offset) {
    return port_of(port)->regs[offset / 4u];
}

size_t fake_i2c_count(enum fake_i2c_event_kind kind) {
    size_t n = 0;
    for (size_t i = 0; i < fake.i2c.log_len; ++i) {
        n += fake.i2c.log[i].kind == kind ? 1u : 0u;
    }
    return n;
}

int fake_i2c_find(enum fake_i2c_event_kind kind, size_t from) {
    for (size_t i = from; i < fake.i2c.log_len; ++i) {
        if (fake.i2c.log[i].kind == kind) {
            return (int)i;
        }
    }
    return -1;
}

/* ------------------------------------------------------------------ I2C */

static void i2c_log(enum fake_i2c_event_kind kind, uint32_t value) {
    assert_true(fake.i2c.log_len < FAKE_LOG_MAX);
    fake.i2c.log[fake.i2c.log_len].kind = kind;
    fake.i2c.log[fake.i2c.log_len].value = value;
    fake.i2c.log_len++;
}

/* Raise flags; they become visible after `latency` further ISR reads. */
static void i2c_raise(uint32_t flags) {
    if (fake.i2c.script.latency == 0u) {
        fake.i2c.regs[I2C_ISR] |= flags;
        return;
    }
    fake.i2c.pending_flags |= flags;
    fake.i2c.pending_reads = fake.i2c.script.latency;
}

static void i2c_stop(void) {
    i2c_log(EV_STOP, 0u);
    fake.i2c.regs[I2C_ISR] &= ~STM32_I2C_ISR_BUSY;
    i2c_raise(STM32_I2C_ISR_STOPF);
}

static bool i2c_stalled(void) {
    const int stall = fake.i2c.script.stall_after_bytes;
    return stall != FAKE_NONE && fake.i2c.bytes_out + fake.i2c.bytes_in == (size_t)stall;
}

/* After a data byte moved: next byte, reload, automatic STOP or TC. */
static void i2c_after_byte(void) {
    fake.i2c.nbytes_left--;
    if (i2c_stalled()) {
        return;
    }
    if (fake.i2c.nbytes_left > 0u) {
        i2c_raise(fake.i2c.reading ? STM32_I2C_ISR_RXNE : STM32_I2C_ISR_TXIS);
        return;
    }
    const uint32_t cr2 = fake.i2c.regs[I2C_CR2];
    if ((cr2 & STM32_I2C_CR2_RELOAD) != 0u) {
        i2c_raise(STM32_I2C_ISR_TCR);
    } else if ((cr2 & STM32_I2C_CR2_AUTOEND) != 0u) {
        i2c_stop();
    } else {
        i2c_raise(STM32_I2C_ISR_TC);
    }
}

static void i2c_start(uint32_t cr2) {
    uint32_t *isr = &fake.i2c.regs[I2C_ISR];
    if ((fake.i2c.regs[I2C_CR1] & STM32_I2C_CR1_PE) == 0u) {
        fake.i2c.protocol_errors++;
    }
    /* A START while the bus is held after TC is a repeated start. */
    const bool restart =
        (*isr & (STM32_I2C_ISR_BUSY | STM32_I2C_ISR_TC)) == (STM32_I2C_ISR_BUSY | STM32_I2C_ISR_TC);
    i2c_log(restart ? EV_RESTART : EV_START, cr2);
    if (!restart) {
        fake.i2c.bytes_out = 0u;
        fake.i2c.bytes_in = 0u;
    }
    *isr &= ~STM32_I2C_ISR_TC;
    *isr |= STM32_I2C_ISR_BUSY;
    fake.i2c.reading = (cr2 & STM32_I2C_CR2_RD_WRN) != 0u;
    fake.i2c.nbytes_left = (cr2 >> STM32_I2C_CR2_NBYTES_SHIFT) & 0xFFu;
    const int addr = (int)((cr2 >> 1) & 0x7Fu);
    if (fake.i2c.script.arlo_at_address) {
        i2c_raise(STM32_I2C_ISR_ARLO); /* the other master keeps the bus: BUSY stays */
        return;
    }
    if (fake.i2c.script.berr_at_address) {
        i2c_raise(STM32_I2C_ISR_BERR); /* ES0250: spurious in master mode, the transfer goes on */
    }
    if (addr != fake.i2c.script.present_addr) {
        i2c_raise(STM32_I2C_ISR_NACKF);
        i2c_stop(); /* the master sends STOP after a NACK by itself */
        return;
    }
    if (i2c_stalled()) {
        return;
    }
    i2c_raise(fake.i2c.reading ? STM32_I2C_ISR_RXNE : STM32_I2C_ISR_TXIS);
}

static void i2c_write(uint32_t index, uint32_t value) {
    uint32_t *regs = fake.i2c.regs;
    switch (index) {
    case I2C_CR1: {
        const bool was_on = (regs[I2C_CR1] & STM32_I2C_CR1_PE) != 0u;
        regs[I2C_CR1] = value;
        if (was_on && (value & STM32_I2C_CR1_PE) == 0u) {
            fake.i2c.software_resets++;
            regs[I2C_ISR] = (regs[I2C_ISR] & ~RESET_CLEARS) | STM32_I2C_ISR_TXE;
            regs[I2C_CR2] &= ~(STM32_I2C_CR2_START | STM32_I2C_CR2_STOP);
            fake.i2c.pending_flags = 0u;
        }
        break;
    }
    case I2C_CR2:
        regs[I2C_CR2] = value & ~(STM32_I2C_CR2_START | STM32_I2C_CR2_STOP);
        if ((value & STM32_I2C_CR2_START) != 0u) {
            i2c_start(value);
        } else if ((value & STM32_I2C_CR2_STOP) != 0u) {
            i2c_stop();
        } else if ((regs[I2C_ISR] & STM32_I2C_ISR_TCR) != 0u) {
            /* Reload: next NBYTES chunk of the same transfer. */
            regs[I2C_ISR] &= ~STM32_I2C_ISR_TCR;
            fake.i2c.nbytes_left = (value >> STM32_I2C_CR2_NBYTES_SHIFT) & 0xFFu;
            if (!i2c_stalled()) {
                i2c_raise(fake.i2c.reading ? STM32_I2C_ISR_RXNE : STM32_I2C_ISR_TXIS);
            }
        } else {
            fake.i2c.protocol_errors++; /* CR2 rewritten outside START/STOP/reload */
        }
        break;
    case I2C_TIMINGR:
        if ((regs[I2C_CR1] & STM32_I2C_CR1_PE) != 0u) {
            fake.i2c.protocol_errors++; /* TIMINGR is writable only with PE = 0 */
        }
        regs[I2C_TIMINGR] = value;
        break;
    case I2C_ICR:
        regs[I2C_ISR] &= ~(value & STM32_I2C_ICR_ALL);
        break;
    case I2C_ISR:
        /* Only TXE is writable by a master: 1 flushes TXDR. */
        if (value != STM32_I2C_ISR_TXE) {
            fake.i2c.protocol_errors++;
        }
        regs[I2C_ISR] |= STM32_I2C_ISR_TXE;
        fake.i2c.txdr_flushes++;
        break;
    case I2C_TXDR: {
        if ((regs[I2C_ISR] & STM32_I2C_ISR_TXIS) == 0u) {
            fake.i2c.protocol_errors++;
            break;
        }
        regs[I2C_ISR] &= ~STM32_I2C_ISR_TXIS;
        i2c_log(EV_BYTE_OUT, value);
        const size_t index_out = fake.i2c.bytes_out++;
        if (fake.i2c.script.nack_byte != FAKE_NONE &&
            index_out == (size_t)fake.i2c.script.nack_byte) {
            i2c_raise(STM32_I2C_ISR_NACKF);
            i2c_stop();
            break;
        }
        i2c_after_byte();
        break;
    }
    default:
        fail_msg("write to I2C register offset 0x%02x", (unsigned)(index * 4u));
    }
}

static uint32_t i2c_read(uint32_t index) {
    uint32_t *regs = fake.i2c.regs;
    switch (index) {
    case I2C_ISR:
        fake.i2c.isr_reads++;
        if (fake.i2c.pending_flags != 0u) {
            if (fake.i2c.pending_reads == 0u) {
                regs[I2C_ISR] |= fake.i2c.pending_flags;
                fake.i2c.pending_flags = 0u;
            } else {
                fake.i2c.pending_reads--;
            }
        }
        return regs[I2C_ISR];
    case I2C_RXDR: {
        if ((regs[I2C_ISR] & STM32_I2C_ISR_RXNE) == 0u) {
            fake.i2c.protocol_errors++;
            return 0u;
        }
        regs[I2C_ISR] &= ~STM32_I2C_ISR_RXNE;
        const uint8_t byte = fake.i2c.script.rx_data[fake.i2c.bytes_in % FAKE_RX_MAX];
        i2c_log(EV_BYTE_IN, byte);
        fake.i2c.bytes_in++;
        i2c_after_byte();
        return byte;
    }
    case I2C_CR1:
    case I2C_CR2:
    case I2C_TIMINGR:
        return regs[index];
    default:
        fail_msg("read of I2C register offset 0x%02x", (unsigned)(index * 4u));
        return 0u;
    }
}

/* ------------------------------------------------------------------ GPIO + bus lines */

static bool master_drives_low(const struct fake_gpio_port *p, uint32_t pin) {
    const uint32_t mode = (p->regs[GPIO_MODER] >> (2u * pin)) & 3u;
    return mode == STM32_GPIO_MODE_OUTPUT && (p->regs[GPIO_ODR] & (1u << pin)) == 0u;
}

/* Recompute the open-drain SCL/SDA levels and record clocks, START and STOP. */
static void update_lines(void) {
    struct fake_i2c_lines *l = &fake.lines;
    const bool scl = !master_drives_low(&fake.port_b, SCL_PIN) && !l->scl_held_low;
    if (l->last_scl && !scl) {
        /* The slave changes SDA only while SCL is low. */
        if (l->scl_rises >= l->sda_release_after_clocks) {
            l->sda_release_after_clocks = 0u;
        }
    }
    if (!l->last_scl && scl) {
        l->scl_rises++;
    }
    const bool slave_holds_sda = l->sda_release_after_clocks != 0u;
    const bool sda = !master_drives_low(&fake.port_b, SDA_PIN) && !slave_holds_sda;
    if (l->last_scl && scl && !l->last_sda && sda) {
        if (l->stops == 0u) {
            l->scl_rises_before_stop = l->scl_rises;
        }
        l->stops++;
    }
    if (l->last_scl && scl && l->last_sda && !sda) {
        l->starts++;
    }
    l->last_scl = scl;
    l->last_sda = sda;
}

static uint32_t port_idr(const struct fake_gpio_port *p) {
    uint32_t idr = 0xFFFFu & ~p->external_low; /* other inputs read high (pull-ups) */
    for (uint32_t pin = 0; pin < 16u; ++pin) {
        if (master_drives_low(p, pin)) {
            idr &= ~(1u << pin);
        }
    }
    if (p == &fake.port_b) {
        idr &= ~((1u << SCL_PIN) | (1u << SDA_PIN));
        idr |=
            (fake.lines.last_scl ? 1u << SCL_PIN : 0u) | (fake.lines.last_sda ? 1u << SDA_PIN : 0u);
    }
    return idr;
}

static void gpio_write(struct fake_gpio_port *p, uint32_t index, uint32_t value) {
    switch (index) {
    case GPIO_IDR:
        fail_msg("write to GPIO IDR");
        break;
    case GPIO_BSRR:
        p->regs[GPIO_ODR] = (p->regs[GPIO_ODR] | (value & 0xFFFFu)) & ~(value >> 16);
        break;
    case GPIO_BRR:
        p->regs[GPIO_ODR] &= ~(value & 0xFFFFu);
        break;
    default:
        p->regs[index] = value;
        break;
    }
    if (p == &fake.port_b) {
        update_lines();
    }
}

static uint32_t gpio_read(const struct fake_gpio_port *p, uint32_t index) {
    switch (index) {
    case GPIO_IDR:
        return port_idr(p);
    case GPIO_BSRR:
    case GPIO_BRR:
        return 0u; /* write-only */
    default:
        return p->regs[index];
    }
}

/* ------------------------------------------------------------------ SysTick, IWDG */

static uint32_t systick_cvr(void) {
    fake.systick.cvr_reads++;
    if (fake.systick.cvr_next < fake.systick.cvr_len) {
        return fake.systick.cvr_queue[fake.systick.cvr_next++];
    }
    return fake.systick.cvr_default;
}

static void iwdg_write(uint32_t index, uint32_t value) {
    if (index == 0u) {
        assert_true(fake.iwdg.kr_len < 16u);
        fake.iwdg.kr_log[fake.iwdg.kr_len++] = value;
        return;
    }
    if (index == 3u) {
        fail_msg("write to IWDG_SR");
    }
    fake.iwdg.regs[index] = value;
}

static uint32_t iwdg_read(uint32_t index) {
    if (index != 3u) {
        return fake.iwdg.regs[index];
    }
    fake.iwdg.sr_reads++;
    if (fake.iwdg.sr_busy_reads == 0u) {
        return 0u;
    }
    if (fake.iwdg.sr_busy_reads != UINT32_MAX) {
        fake.iwdg.sr_busy_reads--;
    }
    return STM32_IWDG_SR_UPDATES;
}

/* ------------------------------------------------------------------ dispatch */

static bool in_block(uintptr_t addr, const uint32_t *regs, size_t count, uint32_t *index) {
    const uintptr_t base = (uintptr_t)regs;
    if (addr < base || addr >= base + count * sizeof(uint32_t)) {
        return false;
    }
    assert_int_equal((addr - base) % 4u, 0u);
    *index = (uint32_t)((addr - base) / 4u);
    return true;
}

static struct fake_gpio_port *port_at(uintptr_t addr, uint32_t *index) {
    struct fake_gpio_port *ports[3] = {&fake.port_a, &fake.port_b, &fake.port_c};
    for (size_t i = 0; i < 3u; ++i) {
        if (in_block(addr, ports[i]->regs, 11u, index)) {
            return ports[i];
        }
    }
    return NULL;
}

uint32_t stm32_reg_hook_read(uintptr_t addr) {
    uint32_t index = 0u;
    struct fake_gpio_port *port = port_at(addr, &index);
    if (in_block(addr, fake.i2c.regs, 11u, &index)) {
        return i2c_read(index);
    }
    if (port != NULL) {
        return gpio_read(port, index);
    }
    if (in_block(addr, fake.iwdg.regs, 5u, &index)) {
        return iwdg_read(index);
    }
    switch (addr) {
    case CORTEX_M_SYST_CSR:
        return fake.systick.csr;
    case CORTEX_M_SYST_RVR:
        return fake.systick.rvr;
    case CORTEX_M_SYST_CVR:
        return systick_cvr();
    case CORTEX_M_ICSR:
        return fake.systick.pending ? CORTEX_M_ICSR_PENDSTSET : 0u;
    default: {
        uint32_t value = 0u;
        if (fake_flash_read(addr, &value) || fake_adc_read(addr, &value)) {
            return value;
        }
        fail_msg("read of unmapped register address %#lx", (unsigned long)addr);
        return 0u;
    }
    }
}

void stm32_reg_hook_write(uintptr_t addr, uint32_t value) {
    uint32_t index = 0u;
    struct fake_gpio_port *port = port_at(addr, &index);
    if (in_block(addr, fake.i2c.regs, 11u, &index)) {
        i2c_write(index, value);
        return;
    }
    if (port != NULL) {
        gpio_write(port, index, value);
        return;
    }
    if (in_block(addr, fake.iwdg.regs, 5u, &index)) {
        iwdg_write(index, value);
        return;
    }
    switch (addr) {
    case CORTEX_M_SYST_CSR:
        fake.systick.csr = value;
        break;
    case CORTEX_M_SYST_RVR:
        fake.systick.rvr = value;
        break;
    case CORTEX_M_SYST_CVR:
        fake.systick.cvr_default = 0u; /* any write clears the counter */
        break;
    default:
        if (!fake_flash_write(addr, value) && !fake_adc_write(addr, value)) {
            fail_msg("write of %#x to unmapped register address %#lx", value, (unsigned long)addr);
        }
    }
}
