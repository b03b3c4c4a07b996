/* I2C1 of the twin: the STM32 I2Cv2 peripheral in master mode (RM0351 §39.4.8 "I2C master
 * mode", §39.7 registers) in front of the simulated bus. The firmware's byte-level sequence
 * (CR2 START/NBYTES/RD_WRN/AUTOEND/RELOAD, TXIS/TXDR, RXNE/RXDR, TC/TCR, STOPF) is turned
 * into the bus's transaction-level calls: a write phase followed by a repeated START read
 * is one write-read transaction, carried out when the read starts; a write ending in STOP
 * is carried out when its last byte has been shifted. Flags appear after the bit time
 * TIMINGR gives (RM0351 §39.4.9), so the firmware's polls see the wire's pace.
 */
#include "twin.h"
#include "twin_world.h"

#include "hal/hal_err.h"

#define I2C_CR1      0x00u
#define I2C_CR2      0x04u
#define I2C_OAR1     0x08u
#define I2C_OAR2     0x0Cu
#define I2C_TIMINGR  0x10u
#define I2C_TIMEOUTR 0x14u
#define I2C_ISR      0x18u
#define I2C_ICR      0x1Cu
#define I2C_PECR     0x20u
#define I2C_RXDR     0x24u
#define I2C_TXDR     0x28u

#define CR1_PE      (1u << 0)
#define CR2_RD_WRN  (1u << 10)
#define CR2_START   (1u << 13)
#define CR2_STOP    (1u << 14)
#define CR2_RELOAD  (1u << 24)
#define CR2_AUTOEND (1u << 25)
#define ISR_TXE     (1u << 0)
#define ISR_TXIS    (1u << 1)
#define ISR_RXNE    (1u << 2)
#define ISR_NACKF   (1u << 4)
#define ISR_STOPF   (1u << 5)
#define ISR_TC      (1u << 6)
#define ISR_TCR     (1u << 7)
#define ISR_BERR    (1u << 8)
#define ISR_ARLO    (1u << 9)
#define ISR_BUSY    (1u << 15)
#define ICR_MASK    0x3F38u /* ADDRCF NACKCF STOPCF BERRCF ARLOCF OVRCF PECCF TIMOUTCF ALERTCF */

enum { EV_NONE, EV_ADDR, EV_TX_SHIFTED, EV_RX_BYTE, EV_STOP };

/* One SCL period from TIMINGR (RM0351 §39.4.9 "I2C master mode", master clock generation):
 * t_SCL = t_SYNC1 + t_SYNC2 + (SCLL + 1 + SCLH + 1) x (PRESC + 1) x t_I2CCLK, with each
 * t_SYNC taken as the analog filter's 50 ns (DS10198 "I2C analog filter", min) plus
 * 3 x t_I2CCLK. I2CCLK is HSI16 (RCC_CCIPR.I2C1SEL = 10b) or PCLK1: 16 MHz either way. */
static uint64_t bit_ps(const struct twin *t) {
    const uint32_t tm = t->i2c.timingr;
    const uint64_t clk_ps = 62500u; /* 1 / 16 MHz */
    const uint64_t presc = ((tm >> 28) & 0xFu) + 1u;
    const uint64_t scll = (tm & 0xFFu) + 1u;
    const uint64_t sclh = ((tm >> 8) & 0xFFu) + 1u;
    return (scll + sclh) * presc * clk_ps + 2u * (50000u + 3u * clk_ps);
}

static void schedule(struct twin *t, uint32_t ev, uint64_t bits) {
    t->i2c.event = ev;
    t->i2c.event_ps = twin_svc_now_ps(&t->svc) + bits * bit_ps(t);
}

static uint32_t prng_next(struct twin_i2c *i) {
    i->prng = i->prng * 1664525u + 1013904223u; /* Numerical Recipes LCG: test draws only */
    return i->prng;
}

/* Errata ES0250 §2.6.4 "Spurious bus error detection in master mode" (STM32L476xx
 * errata sheet): BERR may be set with no effect on the transfer. The test hook raises it
 * at random during transfers so the firmware's handling (clear it, go on) is exercised. */
static void maybe_spurious_berr(struct twin *t) {
    struct twin_i2c *i = &t->i2c;
    if (i->spurious_berr_ppm != 0u && prng_next(i) % 1000000u < i->spurious_berr_ppm) {
        i->isr |= ISR_BERR;
        i->berr_injected++;
    }
}

static void finish_stop(struct twin *t, uint64_t bits) {
    schedule(t, EV_STOP, bits);
}

static bool any_device_acks(struct twin *t, uint8_t addr7) {
    if (t->world == NULL) {
        return false;
    }
    struct sim_i2c_bus *bus = &t->world->rig.bus;
    for (size_t k = 0; k < bus->target_count; ++k) {
        const struct sim_i2c_target *d = &bus->targets[k];
        if (d->ops->acks(d->ctx, addr7)) {
            return true;
        }
    }
    return false;
}

/* Carry out the transaction collected so far; on failure raise the flags the master would
 * see: NACKF (then the automatic STOP), ARLO for a line held by someone else; a stretching
 * device gives nothing at all (the firmware's own timeout ends it). */
static bool transact(struct twin *t, uint8_t *rx, size_t rx_len) {
    struct twin_i2c *i = &t->i2c;
    int rc = HAL_ERR_ADDR_NACK;
    if (t->world != NULL) {
        /* At its START, not now: a write is carried out at its end (its bytes are known only
         * then), after the core has spent its wire time, and sim_i2c adds that time again.
         * Synced to now, each write put the world's clock its length ahead of the core's
         * (2.1 ms after a sensor's configuration write), and a sensor released then booted
         * in the world's time while the firmware's boot window ran out in the core's. */
        twin_world_sync(t->world, i->start_ps / 1000000u);
        rc = twin_world_transfer(t->world, i->addr7, i->tx, i->tx_len, rx, rx_len);
    }
    i->tx_len = 0;
    i->result = rc;
    i->done = true;
    if (rc == HAL_OK) {
        return true;
    }
    if (rc == HAL_ERR_ADDR_NACK || rc == HAL_ERR_DATA_NACK) {
        i->isr |= ISR_NACKF; /* RM0351 §39.4.8: a NACK makes the master send STOP by itself */
        finish_stop(t, 1u);
    } else if (rc == HAL_ERR_TIMEOUT) {
        i->event = EV_NONE; /* SCL held low: nothing happens until the firmware gives up */
        i->event_ps = UINT64_MAX;
    } else {
        i->isr |= ISR_ARLO; /* SDA held low by another driver: arbitration lost (§39.4.8) */
        i->active = false;
        i->isr &= ~ISR_BUSY;
        i->event = EV_NONE;
        i->event_ps = UINT64_MAX;
    }
    return false;
}

static void chunk_end(struct twin *t) {
    struct twin_i2c *i = &t->i2c;
    if ((i->cr2 & CR2_RELOAD) != 0u) {
        i->isr |= ISR_TCR;
        return;
    }
    if ((i->cr2 & CR2_AUTOEND) != 0u) {
        if (!i->reading) {
            if (!transact(t, NULL, 0u)) {
                return;
            }
        }
        finish_stop(t, 1u);
        return;
    }
    i->isr |= ISR_TC; /* bus held: a repeated START or STOP follows */
}

static void process(struct twin *t, uint32_t ev) {
    struct twin_i2c *i = &t->i2c;
    switch (ev) {
    case EV_ADDR:
        if (!i->reading && !any_device_acks(t, i->addr7)) {
            i->tx_len = 0;
            i->result = HAL_ERR_ADDR_NACK;
            i->isr |= ISR_NACKF;
            finish_stop(t, 1u);
            return;
        }
        if (i->nbytes == 0u) {
            chunk_end(t);
        } else if (i->reading) {
            schedule(t, EV_RX_BYTE, 9u);
        } else {
            i->isr |= ISR_TXIS;
        }
        break;
    case EV_TX_SHIFTED:
        i->isr |= ISR_TXE;
        i->txdr_full = false;
        maybe_spurious_berr(t);
        if (--i->nbytes > 0u) {
            i->isr |= ISR_TXIS;
        } else {
            chunk_end(t);
        }
        break;
    case EV_RX_BYTE:
        i->rxdr = i->rx_pos < i->rx_len ? i->rx[i->rx_pos] : 0xFFu;
        i->rx_pos++;
        i->isr |= ISR_RXNE;
        maybe_spurious_berr(t);
        if (--i->nbytes == 0u) {
            chunk_end(t);
        }
        break;
    case EV_STOP:
        i->isr |= ISR_STOPF;
        i->isr &= ~ISR_BUSY; /* BUSY clears on the STOP (§39.7.7) */
        i->active = false;
        break;
    default:
        break;
    }
}

static void update(struct twin *t) {
    struct twin_i2c *i = &t->i2c;
    for (unsigned guard = 0;
         guard < 8u && i->event != EV_NONE && i->event_ps <= twin_svc_now_ps(&t->svc); ++guard) {
        const uint32_t ev = i->event;
        i->event = EV_NONE;
        i->event_ps = UINT64_MAX;
        process(t, ev);
    }
}

void twin_i2c_reset(struct twin *t) {
    const uint32_t ppm = t->i2c.spurious_berr_ppm;
    const uint32_t injected = t->i2c.berr_injected;
    t->i2c = (struct twin_i2c){.isr = ISR_TXE, .event_ps = UINT64_MAX, .prng = 12345u};
    t->i2c.spurious_berr_ppm = ppm;
    t->i2c.berr_injected = injected;
}

/* PE = 0 (RM0351 §39.4.6 "Software reset"): the state machines and ISR flags are reset,
 * TIMINGR and the other configuration registers kept. */
static void software_reset(struct twin *t) {
    struct twin_i2c *i = &t->i2c;
    i->isr = ISR_TXE;
    i->active = false;
    i->tx_len = 0;
    i->txdr_full = false;
    i->event = EV_NONE;
    i->event_ps = UINT64_MAX;
}

uint32_t twin_i2c_read(struct twin *t, uint32_t off) {
    struct twin_i2c *i = &t->i2c;
    switch (off) {
    case I2C_CR1:
        return i->cr1;
    case I2C_CR2:
        return i->cr2;
    case I2C_OAR1:
        return i->oar1;
    case I2C_OAR2:
        return i->oar2;
    case I2C_TIMINGR:
        return i->timingr;
    case I2C_TIMEOUTR:
        return i->timeoutr;
    case I2C_ISR: {
        update(t);
        if (i->event != EV_NONE) {
            /* A poll: the flag it waits for comes with the next bus event. */
            twin_svc_warp_to(&t->svc, i->event_ps);
            update(t);
        }
        return i->isr;
    }
    case I2C_PECR:
        return 0u;
    case I2C_RXDR: {
        update(t);
        const uint32_t v = i->rxdr;
        if ((i->isr & ISR_RXNE) != 0u) {
            i->isr &= ~ISR_RXNE;
            if (i->active && i->reading && i->nbytes > 0u) {
                schedule(t, EV_RX_BYTE, 9u); /* SCL was stretched while RXDR was full */
            }
        }
        return v;
    }
    case I2C_TXDR:
        return i->txdr;
    default:
        twin_svc_violation(&t->svc, "I2C1 register", off, "reserved I2C offset (RM0351 §39.7.12)");
        return 0u;
    }
}

static void start(struct twin *t, uint32_t cr2) {
    struct twin_i2c *i = &t->i2c;
    const bool read = (cr2 & CR2_RD_WRN) != 0u;
    const uint8_t addr7 = (uint8_t)((cr2 >> 1) & 0x7Fu);
    if ((cr2 & (1u << 11)) != 0u) {
        twin_svc_violation(&t->svc, "I2C1_CR2", cr2,
                           "10-bit addressing is not modelled by the twin");
        return;
    }
    if (i->active && (i->isr & ISR_TC) == 0u) {
        twin_svc_violation(&t->svc, "I2C1_CR2", cr2,
                           "START while a transfer is running (RM0351 §39.7.2: START only when "
                           "the bus is free or, for a repeated start, TC = 1)");
        return;
    }
    if (i->active && !i->reading && i->tx_len > 0u && (!read || addr7 != i->addr7)) {
        /* A repeated START that is not the read of the same device: the write so far is a
         * transaction of its own. */
        (void)transact(t, NULL, 0u);
    }
    if (!i->active || !read || addr7 != i->addr7 || i->done) {
        i->start_ps = twin_svc_now_ps(&t->svc); /* a new transaction begins */
    }
    i->isr &= ~(ISR_TC | ISR_NACKF);
    i->active = true;
    i->isr |= ISR_BUSY;
    i->reading = read;
    i->addr7 = addr7;
    i->nbytes = (cr2 >> 16) & 0xFFu;
    i->done = false;
    if (!read) {
        i->tx_len = 0;
        schedule(t, EV_ADDR, 10u); /* START + address + ACK */
        return;
    }
    if ((cr2 & CR2_RELOAD) != 0u) {
        twin_svc_violation(&t->svc, "I2C1_CR2", cr2,
                           "reads longer than 255 bytes are not modelled");
        return;
    }
    i->rx_len = i->nbytes;
    i->rx_pos = 0;
    if (transact(t, i->rx, i->rx_len)) {
        schedule(t, EV_ADDR, 10u);
    } else if (i->event == EV_STOP) {
        schedule(t, EV_STOP, 11u); /* NACK on the address, then the automatic STOP */
    }
}

/* A write of CR2: a new NBYTES after TCR, START (a transfer begins) or STOP. */
static void cr2_write(struct twin *t, uint32_t v) {
    struct twin_i2c *i = &t->i2c;
    if ((i->isr & ISR_TCR) != 0u && (v & CR2_START) == 0u) {
        /* RM0351 §39.4.8 "Master transmitter", NBYTES > 255: a new NBYTES after TCR. */
        i->cr2 = v;
        i->isr &= ~ISR_TCR;
        i->nbytes = (v >> 16) & 0xFFu;
        i->isr |= i->reading ? 0u : ISR_TXIS;
        return;
    }
    i->cr2 = v & ~(CR2_START | CR2_STOP);
    if ((v & CR2_START) != 0u) {
        if ((i->cr1 & CR1_PE) == 0u) {
            twin_svc_violation(&t->svc, "I2C1_CR2", v, "START with PE = 0 (RM0351 §39.7.2)");
            return;
        }
        start(t, v);
    } else if ((v & CR2_STOP) != 0u && i->active) {
        if (!i->reading && i->tx_len > 0u && !transact(t, NULL, 0u)) {
            return;
        }
        i->isr &= ~ISR_TC;
        finish_stop(t, 1u);
    }
}

void twin_i2c_write(struct twin *t, uint32_t off, uint32_t v) {
    struct twin_i2c *i = &t->i2c;
    update(t);
    switch (off) {
    case I2C_CR1:
        if ((v & CR1_PE) == 0u && (i->cr1 & CR1_PE) != 0u) {
            software_reset(t);
        }
        if ((v & ~(CR1_PE | 0xF00u | (1u << 12))) != 0u) {
            twin_svc_violation(&t->svc, "I2C1_CR1", v,
                               "interrupts, DMA, slave features are not modelled (polled master)");
        }
        i->cr1 = v;
        break;
    case I2C_CR2:
        cr2_write(t, v);
        break;
    case I2C_OAR1:
        i->oar1 = v;
        break;
    case I2C_OAR2:
        i->oar2 = v;
        break;
    case I2C_TIMINGR:
        if ((i->cr1 & CR1_PE) != 0u) {
            twin_svc_violation(&t->svc, "I2C1_TIMINGR", v,
                               "TIMINGR written while PE = 1 (RM0351 §39.7.5: only when the "
                               "I2C is disabled)");
        }
        i->timingr = v;
        break;
    case I2C_TIMEOUTR:
        i->timeoutr = v;
        break;
    case I2C_ISR:
        /* Only TXE (flush TXDR) is writable in master mode (RM0351 §39.7.7). */
        if ((v & ISR_TXE) != 0u) {
            i->isr |= ISR_TXE;
        }
        break;
    case I2C_ICR:
        i->isr &= ~(v & ICR_MASK);
        break;
    case I2C_TXDR:
        if ((i->isr & ISR_TXE) == 0u) {
            twin_svc_violation(&t->svc, "I2C1_TXDR", v,
                               "TXDR written while TXE = 0: the byte not yet sent is overwritten "
                               "(RM0351 §39.7.11)");
        }
        i->txdr = v & 0xFFu;
        if (i->active && !i->reading && (i->isr & ISR_TXIS) != 0u) {
            if (i->tx_len < TWIN_I2C_BUF) {
                i->tx[i->tx_len++] = (uint8_t)v;
            }
            i->isr &= ~(ISR_TXIS | ISR_TXE);
            i->txdr_full = true;
            schedule(t, EV_TX_SHIFTED, 9u);
        } else {
            i->isr &= ~ISR_TXE; /* held in TXDR until a transfer asks for it */
        }
        break;
    default:
        twin_svc_violation(&t->svc, "I2C1 register", off, "reserved I2C offset (RM0351 §39.7.12)");
        break;
    }
}
