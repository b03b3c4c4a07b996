/* USART2 of the twin (RM0351 §40): 8N1 transmitter into the host's telemetry decoder (paced by
 * BRR at PCLK1 = SYSCLK) and a receiver fed with the host's commands at the host's 115200 Bd,
 * with the RXNE/ORE, TXE and TC interrupts to the NVIC (IRQ 38). */
#include "twin.h"

#define USART_CR1  0x00u
#define USART_CR2  0x04u
#define USART_CR3  0x08u
#define USART_BRR  0x0Cu
#define USART_GTPR 0x10u
#define USART_RTOR 0x14u
#define USART_RQR  0x18u
#define USART_ISR  0x1Cu
#define USART_ICR  0x20u
#define USART_RDR  0x24u
#define USART_TDR  0x28u

#define CR1_UE     (1u << 0)
#define CR1_RE     (1u << 2)
#define CR1_TE     (1u << 3)
#define CR1_RXNEIE (1u << 5)
#define CR1_TCIE   (1u << 6)
#define CR1_TXEIE  (1u << 7)
/* The CR1 bits the model implements (§40.8.1); any other is a configuration it does not
 * model (word length, parity, oversampling by 8, other interrupts...). */
#define CR1_MODELLED (CR1_UE | CR1_RE | CR1_TE | CR1_RXNEIE | CR1_TCIE | CR1_TXEIE)
#define ISR_ORE      (1u << 3)
#define ISR_RXNE     (1u << 5)
#define ISR_TC       (1u << 6)
#define ISR_TXE      (1u << 7)
#define ISR_TEACK    (1u << 21)
#define ISR_REACK    (1u << 22)

/* One 8N1 frame (start, 8 data, stop: 10 bits) at baud = f_CK / USARTDIV, oversampling by
 * 16 (RM0351 §40.5.4 "Baud rate generation"). */
static uint64_t frame_ps(const struct twin *t) {
    const uint32_t brr = t->usart.brr != 0u ? t->usart.brr : 1u;
    return 10u * (uint64_t)brr * (1000000000000ull / t->sysclk_hz);
}

/* The host's own transmitter: 115200 Bd 8N1 exactly (a PC's UART or the ST-LINK's virtual COM
 * port), bytes back to back at the line rate: 10 bits, 86.806 us a byte. */
#define HOST_FRAME_PS (10u * 1000000000000ull / TWIN_HOST_BAUD)

/* The interrupt line to the NVIC (RM0351 §40.7 "USART interrupts"): TXE
 * with TXEIE, TC with TCIE, RXNE or ORE with RXNEIE; nothing while UE = 0. */
static bool line(const struct twin_usart *u) {
    if ((u->cr1 & CR1_UE) == 0u) {
        return false;
    }
    return ((u->cr1 & CR1_TXEIE) != 0u && (u->isr & ISR_TXE) != 0u) ||
           ((u->cr1 & CR1_TCIE) != 0u && (u->isr & ISR_TC) != 0u) ||
           ((u->cr1 & CR1_RXNEIE) != 0u && (u->isr & (ISR_RXNE | ISR_ORE)) != 0u);
}

/* The transmitter up to `now`: the shift register's byte to the host, TDR's into it. */
static void update_tx(struct twin *t, uint64_t now) {
    struct twin_usart *u = &t->usart;
    if (u->shift_busy && now >= u->shift_done_ps) {
        u->shift_busy = false;
        if (u->on_tx != NULL) {
            u->on_tx(u->tx_ctx, u->shift, u->shift_done_ps);
        }
        u->bytes_tx++;
        if ((u->isr & ISR_TXE) == 0u) {
            /* TDR -> shift register as soon as it is free (§40.5.2). */
            u->shift = (uint8_t)u->tdr;
            u->shift_busy = true;
            u->shift_done_ps += frame_ps(t);
            u->isr |= ISR_TXE;
        } else {
            u->isr |= ISR_TC;
        }
    }
}

void twin_usart_update(struct twin *t) {
    struct twin_usart *u = &t->usart;
    const uint64_t now = twin_svc_now_ps(&t->svc);
    const bool before = line(u);
    update_tx(t, now);
    const bool rx_on = (u->cr1 & (CR1_UE | CR1_RE)) == (CR1_UE | CR1_RE);
    while (rx_on && u->rx_count > 0u && now >= u->rx_next_ps) {
        if ((u->isr & ISR_RXNE) != 0u) {
            /* §40.5.3 "Overrun error": a byte arrives with RXNE set; RDR keeps the old one,
             * the new one is lost; ORE stays set until ICR.ORECF. */
            u->isr |= ISR_ORE;
            u->overruns++;
        } else {
            u->rdr = u->rxq[u->rx_head];
            u->isr |= ISR_RXNE;
        }
        u->rx_head = (u->rx_head + 1u) % TWIN_USART_RXQ;
        u->rx_count--;
        u->bytes_rx++;
        u->rx_next_ps += HOST_FRAME_PS;
    }
    if (!before && line(u)) {
        twin_svc_kick(&t->svc); /* the NVIC sees the line at the next block */
    }
}

bool twin_usart_irq(const struct twin *t) {
    return line(&t->usart);
}

uint64_t twin_usart_next_event_ps(const struct twin *t) {
    const struct twin_usart *u = &t->usart;
    uint64_t e = UINT64_MAX;
    if (u->shift_busy && (u->cr1 & (CR1_TXEIE | CR1_TCIE)) != 0u) {
        e = u->shift_done_ps; /* TXE (TDR moves on) or TC then */
    }
    if (u->rx_count > 0u && (u->cr1 & CR1_RXNEIE) != 0u && u->rx_next_ps < e) {
        e = u->rx_next_ps; /* RXNE or ORE then */
    }
    return e;
}

void twin_usart_reset(struct twin *t) {
    struct twin_usart *u = &t->usart;
    void (*cb)(void *, uint8_t, uint64_t) = u->on_tx;
    void *ctx = u->tx_ctx;
    const uint64_t tx = u->bytes_tx, rx = u->bytes_rx, ovr = u->overruns;
    *u = (struct twin_usart){.isr = ISR_TXE | ISR_TC}; /* ISR reset 0x020000C0 (§40.8.8) */
    u->on_tx = cb;
    u->tx_ctx = ctx;
    u->bytes_tx = tx;
    u->bytes_rx = rx;
    u->overruns = ovr;
}

uint64_t twin_usart_send_to_mcu(struct twin *t, const uint8_t *data, unsigned len) {
    struct twin_usart *u = &t->usart;
    if (u->rx_count + len > TWIN_USART_RXQ || len == 0u) {
        return 0u;
    }
    if (u->rx_count == 0u) {
        u->rx_next_ps = twin_svc_now_ps(&t->svc) + HOST_FRAME_PS;
    }
    for (unsigned k = 0; k < len; ++k) {
        u->rxq[(u->rx_head + u->rx_count) % TWIN_USART_RXQ] = data[k];
        u->rx_count++;
    }
    return u->rx_next_ps + (uint64_t)(u->rx_count - 1u) * HOST_FRAME_PS;
}

uint32_t twin_usart_read(struct twin *t, uint32_t off) {
    struct twin_usart *u = &t->usart;
    twin_usart_update(t);
    switch (off) {
    case USART_CR1:
        return u->cr1;
    case USART_CR2:
        return u->cr2;
    case USART_CR3:
        return u->cr3;
    case USART_BRR:
        return u->brr;
    case USART_GTPR:
        return u->gtpr;
    case USART_RTOR:
        return u->rtor;
    case USART_RQR:
        return 0u;
    case USART_ISR: {
        uint32_t v = u->isr;
        if ((u->cr1 & CR1_UE) != 0u) {
            v |= ((u->cr1 & CR1_TE) != 0u ? ISR_TEACK : 0u) | ((u->cr1 & CR1_RE) ? ISR_REACK : 0u);
        }
        /* A TXE poll: skip to the end of the frame. Not with a received byte waiting (RXNE):
         * that is the interrupt handler's one look at ISR, which reads RDR next; skipping a
         * byte time there left the byte unread until the next one overran it (found by
         * twin.commands_every_type: 3 overruns with the raw stream keeping TXE clear). */
        if ((v & ISR_TXE) == 0u && u->shift_busy && (u->isr & ISR_RXNE) == 0u) {
            twin_svc_warp_to(&t->svc, u->shift_done_ps);
            twin_usart_update(t);
            v = (v & ~(ISR_TXE | ISR_TC)) | (u->isr & (ISR_TXE | ISR_TC | ISR_RXNE));
        }
        return v;
    }
    case USART_RDR: {
        const uint32_t v = u->rdr;
        u->isr &= ~ISR_RXNE;
        return v;
    }
    case USART_TDR:
        return u->tdr;
    default:
        twin_svc_violation(&t->svc, "USART2 register", off,
                           "reserved USART offset (RM0351 §40.8.12)");
        return 0u;
    }
}

/* A write of CR1: only the bits the model implements. */
static void cr1_write(struct twin *t, uint32_t v) {
    if ((v & ~CR1_MODELLED) != 0u) {
        twin_svc_violation(&t->svc, "USART2_CR1", v,
                           "a CR1 bit the twin does not model (RM0351 §40.8.1): 8N1, "
                           "oversampling by 16, RXNE/TXE/TC interrupts only");
    }
    t->usart.cr1 = v;
}

void twin_usart_write(struct twin *t, uint32_t off, uint32_t v) {
    struct twin_usart *u = &t->usart;
    twin_usart_update(t);
    switch (off) {
    case USART_CR1:
        cr1_write(t, v);
        break;
    case USART_CR2:
    case USART_CR3:
        if ((u->cr1 & CR1_UE) != 0u) {
            twin_svc_violation(&t->svc, off == USART_CR2 ? "USART2_CR2" : "USART2_CR3", v,
                               "written while UE = 1 (RM0351 §40.8.2/§40.8.3)");
        }
        if (off == USART_CR2) {
            u->cr2 = v;
        } else {
            u->cr3 = v;
        }
        break;
    case USART_BRR:
        if ((u->cr1 & CR1_UE) != 0u) {
            twin_svc_violation(&t->svc, "USART2_BRR", v,
                               "BRR written while UE = 1 (RM0351 §40.8.4)");
        }
        u->brr = v & 0xFFFFu;
        break;
    case USART_GTPR:
        u->gtpr = v;
        break;
    case USART_RTOR:
        u->rtor = v;
        break;
    case USART_RQR:
        break;
    case USART_ICR:
        u->isr &= ~(v & 0x00121B5Fu);
        break;
    case USART_TDR:
        if ((u->cr1 & (CR1_UE | CR1_TE)) != (CR1_UE | CR1_TE)) {
            twin_svc_violation(&t->svc, "USART2_TDR", v,
                               "TDR written with UE or TE clear: nothing is sent");
            break;
        }
        if ((u->isr & ISR_TXE) == 0u) {
            twin_svc_violation(
                &t->svc, "USART2_TDR", v,
                "TDR written while TXE = 0 (RM0351 §40.8.9: the previous byte is lost)");
        }
        u->tdr = v & 0x1FFu;
        u->isr &= ~ISR_TC;
        if (!u->shift_busy) {
            u->shift = (uint8_t)v;
            u->shift_busy = true;
            u->shift_done_ps = twin_svc_now_ps(&t->svc) + frame_ps(t);
        } else {
            u->isr &= ~ISR_TXE;
        }
        break;
    case USART_ISR:
    case USART_RDR:
        twin_svc_violation(&t->svc, "USART2 read-only register", v, "ISR and RDR are read-only");
        break;
    default:
        twin_svc_violation(&t->svc, "USART2 register", off,
                           "reserved USART offset (RM0351 §40.8.12)");
        break;
    }
    /* A write that raises the line (an enable set) or starts a byte whose end raises it:
     * stop at the next block so the core takes the interrupt, and sees the new event. */
    twin_svc_kick(&t->svc);
}
