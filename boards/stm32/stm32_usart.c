/* Interrupt-driven transmit and receive on an STM32 USARTv2 through ring buffers. */
#include "stm32_usart.h"

#include <stdbool.h>

#include "stm32_irq.h"

/* USARTv2 register offsets and bits (RM0351 §40.8 / RM0444 §33.8). */
#define USART_CR1    0x00u
#define USART_BRR    0x0Cu
#define USART_ISR    0x1Cu
#define USART_ICR    0x20u
#define USART_RDR    0x24u
#define USART_TDR    0x28u
#define USART_CR1_UE (1u << 0)
#define USART_CR1_RE (1u << 2)
#define USART_CR1_TE (1u << 3)
#define USART_CR1_RXNEIE                                                                           \
    (1u << 5) /* interrupt on RXNE, and on ORE (RM0351 §40.7 "USART interrupts") */
#define USART_CR1_TXEIE (1u << 7)   /* interrupt on TXE */
#define USART_ISR_ORE   (1u << 3)   /* overrun error; cleared by ICR.ORECF (same bit) */
#define USART_ISR_RXNE  (1u << 5)   /* RXNE (L4) / RXFNE (G0, FIFO disabled: same meaning) */
#define USART_ISR_TC    (1u << 6)   /* transmission complete: the last stop bit has gone */
#define USART_ISR_TXE   (1u << 7)   /* TXE (L4) / TXFNF (G0, FIFO disabled: same meaning) */
#define NVIC_ISER       0xE000E100u /* set-enable registers, 32 IRQs each (ARMv7-M B3.4.4) */

void stm32_usart_init(struct stm32_usart *usart) {
    usart->tx_head = usart->tx_tail = usart->rx_head = usart->rx_tail = 0u;
    stm32_reg_write(usart->base + USART_CR1, 0u);
    stm32_reg_write(usart->base + USART_BRR, usart->brr);
    stm32_reg_write(usart->base + USART_CR1,
                    USART_CR1_TE | USART_CR1_RE | USART_CR1_RXNEIE | USART_CR1_UE);
    stm32_reg_write(NVIC_ISER + 4u * (usart->irq / 32u), 1u << (usart->irq % 32u));
}

void stm32_usart_irq(struct stm32_usart *usart) {
    const uint32_t isr = stm32_reg_read(usart->base + USART_ISR);
    if ((isr & USART_ISR_ORE) != 0u) {
        ++usart->overruns; /* counted; the frame decoder resynchronises on what follows */
        stm32_reg_write(usart->base + USART_ICR, USART_ISR_ORE);
    }
    if ((isr & USART_ISR_RXNE) != 0u) {
        const uint8_t byte = (uint8_t)stm32_reg_read(usart->base + USART_RDR); /* clears RXNE */
        const uint32_t head = usart->rx_head;
        if (head - usart->rx_tail < STM32_USART_RX_RING) {
            usart->rx[head % STM32_USART_RX_RING] = byte;
            usart->rx_head = head + 1u;
        } else {
            ++usart->rx_full;
        }
    }
    const uint32_t cr1 = stm32_reg_read(usart->base + USART_CR1);
    if ((cr1 & USART_CR1_TXEIE) != 0u && (isr & USART_ISR_TXE) != 0u) {
        const uint32_t tail = usart->tx_tail;
        if (tail != usart->tx_head) {
            stm32_reg_write(usart->base + USART_TDR, usart->tx[tail % STM32_USART_TX_RING]);
            usart->tx_tail = tail + 1u;
        } else {
            /* Empty: TXE stays set, so the interrupt goes off until there is more. */
            stm32_reg_write(usart->base + USART_CR1, cr1 & ~USART_CR1_TXEIE);
        }
    }
}

/* Queue `len` bytes if they all fit; false (nothing queued) if not. */
static bool tx_queue(struct stm32_usart *usart, const uint8_t *data, size_t len) {
    const uint32_t head = usart->tx_head;
    if (len > STM32_USART_TX_RING - (head - usart->tx_tail)) {
        return false;
    }
    for (size_t i = 0; i < len; ++i) {
        usart->tx[(head + (uint32_t)i) % STM32_USART_TX_RING] = data[i];
    }
    __asm__ volatile("" ::: "memory"); /* the bytes are in place before the handler sees them */
    usart->tx_head = head + (uint32_t)len;
    /* masked: a read-modify-write of CR1 that the IRQ handler also changes (TXEIE) */
    const uint32_t primask = irq_save();
    stm32_reg_modify(usart->base + USART_CR1, 0u, USART_CR1_TXEIE);
    irq_restore(primask);
    return true;
}

void stm32_usart_log_write(void *ctx, const char *text, size_t len) {
    struct stm32_usart *usart = ctx;
    if (!tx_queue(usart, (const uint8_t *)text, len)) {
        usart->dropped += (uint32_t)len;
    }
}

/* One byte by polling TXE, bounded by spin_max polls; false if TXE never came. */
static bool put_polled(struct stm32_usart *usart, uint8_t byte) {
    for (uint32_t spins = 0; spins < usart->spin_max; ++spins) {
        if ((stm32_reg_read(usart->base + USART_ISR) & USART_ISR_TXE) != 0u) {
            stm32_reg_write(usart->base + USART_TDR, byte);
            return true;
        }
    }
    return false;
}

void stm32_usart_fault_write(struct stm32_usart *usart, const char *text, size_t len) {
    /* The handler may not run (a fault masks it): take the transmitter over. */
    stm32_reg_modify(usart->base + USART_CR1, USART_CR1_TXEIE, 0u);
    for (uint32_t n = 0; n < STM32_USART_TX_RING && usart->tx_tail != usart->tx_head; ++n) {
        if (!put_polled(usart, usart->tx[usart->tx_tail % STM32_USART_TX_RING])) {
            ++usart->dropped;
        }
        usart->tx_tail = usart->tx_tail + 1u;
    }
    for (size_t i = 0; i < len; ++i) {
        if (!put_polled(usart, (uint8_t)text[i])) {
            ++usart->dropped;
        }
    }
}

void stm32_usart_flush(const struct stm32_usart *usart) {
    for (uint32_t spins = 0; spins < usart->spin_max; ++spins) {
        if ((stm32_reg_read(usart->base + USART_ISR) & USART_ISR_TC) != 0u) {
            return;
        }
    }
}

void cortex_m_system_reset(void) {
    __asm__ volatile("dsb" ::: "memory");
    stm32_reg_write(0xE000ED0Cu, (0x05FAu << 16) | (1u << 2)); /* AIRCR: VECTKEY | SYSRESETREQ */
    __asm__ volatile("dsb" ::: "memory");
    for (;;) {
        /* the reset takes effect within a few cycles */
    }
}

static size_t serial_write(void *ctx, const uint8_t *data, size_t len) {
    return tx_queue(ctx, data, len) ? len : 0u; /* a frame goes whole or not at all */
}

static size_t serial_read(void *ctx, uint8_t *buf, size_t max) {
    struct stm32_usart *usart = ctx;
    const uint32_t tail = usart->rx_tail;
    const uint32_t avail = usart->rx_head - tail;
    const size_t n = avail < max ? avail : max;
    for (size_t i = 0; i < n; ++i) {
        buf[i] = usart->rx[(tail + (uint32_t)i) % STM32_USART_RX_RING];
    }
    __asm__ volatile("" ::: "memory"); /* copied before the handler may overwrite them */
    usart->rx_tail = tail + (uint32_t)n;
    return n;
}

static uint32_t serial_rx_lost(void *ctx) {
    const struct stm32_usart *usart = ctx;
    return usart->overruns + usart->rx_full;
}

const struct hal_serial_ops stm32_usart_serial_ops = {
    .write = serial_write, .read = serial_read, .rx_lost = serial_rx_lost};
