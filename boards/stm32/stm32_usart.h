/*
 * Polled transmit on an STM32 "USARTv2" peripheral (the register layout shared
 * by STM32L4 and STM32G0: RM0351 §40.8, RM0444 §33.8). Used for the log/UART.
 */
#ifndef BOARDS_STM32_USART_H
#define BOARDS_STM32_USART_H

#include <stddef.h>
#include <stdint.h>

#include "hal/hal_serial.h"

#include "stm32_reg.h"

struct stm32_usart {
    uintptr_t base;    /* peripheral base address */
    uint32_t brr;      /* BRR value: kernel clock / baud rate (oversampling 16) */
    uint32_t spin_max; /* TXE polls per byte before the byte is dropped and counted */
    uint32_t dropped;  /* bytes dropped because TXE never came (mutable) */
    uint32_t overruns; /* receive overruns (bytes lost before they were read; mutable) */
};

/* Enable the transmitter and the receiver (the caller has clocked the peripheral and set
 * the pins). */
void stm32_usart_init(struct stm32_usart *usart);

/* hal_log write: polled, each byte bounded by spin_max polls. */
void stm32_usart_log_write(void *ctx, const char *text, size_t len);

/* Request a system reset (ARMv6-M/ARMv7-M AIRCR.SYSRESETREQ with VECTKEY 0x05FA). */
__attribute__((noreturn)) void cortex_m_system_reset(void);

/* hal_serial over the same USART (ctx: struct stm32_usart *): polled, bounded per byte. */
extern const struct hal_serial_ops stm32_usart_serial_ops;

/* Wait (at most spin_max polls) until the last byte written has left the transmitter
 * (ISR.TC): before a reset, which would cut it off. */
void stm32_usart_flush(const struct stm32_usart *usart);

#endif /* BOARDS_STM32_USART_H */
