/* Transmit on an STM32 USARTv2 for the log and telemetry link (stm32_usart.h). */
#include "stm32_usart.h"

/* USARTv2 register offsets and bits (RM0351 §40.8 / RM0444 §33.8). */
#define USART_CR1      0x00u
#define USART_BRR      0x0Cu
#define USART_ISR      0x1Cu
#define USART_ICR      0x20u
#define USART_RDR      0x24u
#define USART_TDR      0x28u
#define USART_CR1_RE   (1u << 2)
#define USART_ISR_ORE  (1u << 3) /* overrun error; cleared by ICR.ORECF (same bit) */
#define USART_ISR_RXNE (1u << 5) /* RXNE (L4) / RXFNE (G0, FIFO disabled: same meaning) */
#define USART_CR1_UE   (1u << 0)
#define USART_CR1_TE   (1u << 3)
#define USART_ISR_TXE  (1u << 7) /* TXE (L4) / TXFNF (G0, FIFO disabled: same meaning) */
#define USART_ISR_TC   (1u << 6) /* transmission complete: the last stop bit has gone */

void stm32_usart_init(struct stm32_usart *usart) {
    stm32_reg_write(usart->base + USART_CR1, 0u);
    stm32_reg_write(usart->base + USART_BRR, usart->brr);
    stm32_reg_write(usart->base + USART_CR1, USART_CR1_TE | USART_CR1_RE | USART_CR1_UE);
}

void stm32_usart_log_write(void *ctx, const char *text, size_t len) {
    struct stm32_usart *usart = ctx;
    for (size_t i = 0; i < len; ++i) {
        uint32_t spins = 0;
        while ((stm32_reg_read(usart->base + USART_ISR) & USART_ISR_TXE) == 0u &&
               spins < usart->spin_max) {
            ++spins;
        }
        if (spins >= usart->spin_max) {
            ++usart->dropped;
            continue;
        }
        stm32_reg_write(usart->base + USART_TDR, (uint8_t)text[i]);
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
    struct stm32_usart *usart = ctx;
    const uint32_t dropped = usart->dropped;
    stm32_usart_log_write(ctx, (const char *)data, len);
    return usart->dropped == dropped ? len : 0u; /* a frame with a lost byte is lost */
}

static size_t serial_read(void *ctx, uint8_t *buf, size_t max) {
    struct stm32_usart *usart = ctx;
    size_t n = 0;
    const uint32_t isr = stm32_reg_read(usart->base + USART_ISR);
    if ((isr & USART_ISR_ORE) != 0u) {
        ++usart->overruns; /* counted; the frame decoder resynchronises on what follows */
        stm32_reg_write(usart->base + USART_ICR, USART_ISR_ORE);
    }
    while (n < max && (stm32_reg_read(usart->base + USART_ISR) & USART_ISR_RXNE) != 0u) {
        buf[n++] = (uint8_t)stm32_reg_read(usart->base + USART_RDR);
    }
    return n;
}

const struct hal_serial_ops stm32_usart_serial_ops = {.write = serial_write, .read = serial_read};
