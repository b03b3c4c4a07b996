/*
 * Interrupt-driven transmit and receive on an STM32 "USARTv2" peripheral (the register
 * layout shared by STM32L4 and STM32G0: RM0351 §40.8, RM0444 §33.8), through a ring buffer
 * each way, for the log text and the telemetry link: nothing in the main loop waits on the
 * line. The USART's IRQ handler of the board calls stm32_usart_irq().
 */
#ifndef BOARDS_STM32_USART_H
#define BOARDS_STM32_USART_H

#include <stddef.h>
#include <stdint.h>

#include "hal/hal_serial.h"

#include "stm32_reg.h"

/*
 * Buffer sizes from the worst case, at 115200 Bd 8N1 (10 bits a byte: 86.8 us a byte, 11 520
 * bytes/s, 230 bytes per 20 ms sample period):
 *
 * Command rate: a host sends at most STM32_USART_BURST commands back to back before it waits
 * for their answers (tools/tof_telemetry.py sends one and waits; the twin sends three).
 * Commands are 7..16 bytes; each is answered by an ack (11 bytes), a status request (7
 * bytes) also by a status frame (23): at most 34 bytes of answer per command.
 *
 * Transmit. What one loop iteration can queue at once, with the frame sizes of
 * docs/reference/telemetry-protocol.md (overhead 7 bytes): a window's estimates (4 estimators x 54
 * = 216 with every estimator built in, 108 in the flight image), a raw sample 24, the health frame
 * 151 (at most once a second), a status 23, the answers to a burst 8 x 34 = 272: 686 bytes, plus
 * what the line has not yet drained of the iteration before (every mode sends < 70 % of the
 * line's rate, docs/reference/telemetry-protocol.md, so less than one period's 230 bytes is left):
 * 916 < 1024. A frame that does not fit whole is dropped and counted (link tx_dropped), never half
 * sent.
 *
 * Receive. The main loop drains the buffer once per iteration; an idle loop sleeps until the
 * next sample, so the longest gap between two drains is one sample period plus the longest
 * iteration: 20 ms + 10 ms (the loop's budget, half the period) = 30 ms. A burst is at most
 * 8 x 16 = 128 bytes; 256 bytes hold two bursts within one gap, or 22 ms of a line busy
 * without a pause. A byte that finds the buffer full is lost and counted (rx_full).
 */
#define STM32_USART_BURST   8u
#define STM32_USART_TX_RING 1024u /* power of two */
#define STM32_USART_RX_RING 256u  /* power of two */

struct stm32_usart {
    uintptr_t base;    /* peripheral base address */
    uint32_t brr;      /* BRR value: kernel clock / baud rate (oversampling 16) */
    uint32_t spin_max; /* TXE polls per byte of a polled (fault) write before it gives up */
    uint32_t irq;      /* NVIC interrupt number of the USART (board's vector table) */
    /* Mutable. Indices run free (uint32 wraps; the sizes are powers of two): the main loop
     * alone writes tx_head and rx_tail, the IRQ handler alone tx_tail and rx_head. */
    volatile uint32_t tx_head, tx_tail, rx_head, rx_tail;
    uint32_t dropped;           /* log bytes dropped: transmit buffer full, or TXE never came */
    volatile uint32_t overruns; /* receiver overruns (ISR.ORE): a byte came with RDR full */
    volatile uint32_t rx_full;  /* bytes received with the receive buffer full, lost */
    uint8_t tx[STM32_USART_TX_RING];
    uint8_t rx[STM32_USART_RX_RING];
};

/* Enable the transmitter, the receiver and its interrupt, and the USART's IRQ in the NVIC
 * (the caller has clocked the peripheral and set the pins). Empties both buffers. */
void stm32_usart_init(struct stm32_usart *usart);

/* The USART's interrupt: one received byte into the receive buffer (an overrun counted and
 * cleared), one byte of the transmit buffer into TDR (the TXE interrupt off once it is
 * empty). Bounded: a few register accesses. */
void stm32_usart_irq(struct stm32_usart *usart);

/* hal_log write: the text into the transmit buffer; what does not fit is dropped and
 * counted (`dropped`). Never waits. */
void stm32_usart_log_write(void *ctx, const char *text, size_t len);

/* A fault handler's write (interrupts may be masked): what the transmit buffer holds, then
 * `text`, written by polling TXE, each byte bounded by spin_max polls. */
void stm32_usart_fault_write(struct stm32_usart *usart, const char *text, size_t len);

/* Request a system reset (ARMv6-M/ARMv7-M AIRCR.SYSRESETREQ with VECTKEY 0x05FA). */
__attribute__((noreturn)) void cortex_m_system_reset(void);

/* hal_serial over the same USART (ctx: struct stm32_usart *): a frame goes into the
 * transmit buffer whole or not at all; reads take from the receive buffer. Never waits. */
extern const struct hal_serial_ops stm32_usart_serial_ops;

/* Wait (at most spin_max polls) until the last byte written has left the transmitter
 * (ISR.TC): before a reset, which would cut it off. */
void stm32_usart_flush(const struct stm32_usart *usart);

#endif /* BOARDS_STM32_USART_H */
