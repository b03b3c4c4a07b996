/*
 * Register-level fakes of the STM32 peripherals the board drivers use, for
 * host tests. The drivers are compiled with STM32_REG_HOOKS, so every register
 * access lands in stm32_reg_hook_read/write (fake_stm32.c), which finds the
 * fake by address and applies the hardware's side effects:
 *
 *  - I2C (I2Cv2, RM0351 §39): a register block in RAM plus a scripted slave.
 *    START/TXDR/RXDR/CR2-reload/ICR/PE behave as in the reference manual's
 *    master flows; the script injects address NACK, data NACK at byte N,
 *    arbitration loss, bus error, BUSY before START, a slave that stops
 *    answering (no TXIS/RXNE ever) and a latency in ISR reads before each
 *    flag appears. Every START, repeated START, STOP and data byte is logged.
 *  - GPIO ports: MODER/OTYPER/PUPDR/AFR/ODR/BSRR/IDR in RAM; pins 8 (SCL) and
 *    9 (SDA) of port B form an open-drain bus with a slave that can hold SDA
 *    low until it has seen N SCL clocks, or hold SCL low for ever.
 *  - SysTick/ICSR at their architectural addresses, with scripted counter
 *    values; IWDG with a status register that clears after N reads.
 * Any access to an address no fake owns fails the test.
 */
#ifndef TESTS_BOARDS_FAKE_STM32_H
#define TESTS_BOARDS_FAKE_STM32_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "hal/hal_time.h"

#define FAKE_NONE      (-1)
#define FAKE_LOG_MAX   2048
#define FAKE_RX_MAX    1024
#define FAKE_CVR_QUEUE 16

/* Bus events in the I2C log. */
enum fake_i2c_event_kind { EV_START, EV_RESTART, EV_BYTE_OUT, EV_BYTE_IN, EV_STOP };

struct fake_i2c_event {
    enum fake_i2c_event_kind kind;
    uint32_t value; /* START: CR2 as written; BYTE: the byte */
};

/* What the slave and bus do; set before the call under test. */
struct fake_i2c_script {
    int present_addr;      /* 7-bit address that acknowledges; FAKE_NONE: nobody */
    int nack_byte;         /* index of the written data byte the slave NACKs; FAKE_NONE */
    bool arlo_at_address;  /* another master wins arbitration during the address */
    bool berr_at_address;  /* a misplaced START/STOP during the address */
    int stall_after_bytes; /* after this many data bytes nothing more happens; FAKE_NONE */
    bool busy_at_start;    /* ISR.BUSY already set before the driver starts */
    uint32_t latency;      /* ISR reads before a newly raised flag becomes visible */
    uint8_t rx_data[FAKE_RX_MAX];
};

struct fake_i2c {
    uint32_t regs[11]; /* the register block the driver's base points at (0x00..0x28) */
    struct fake_i2c_script script;
    /* observations */
    struct fake_i2c_event log[FAKE_LOG_MAX];
    size_t log_len;
    uint32_t isr_reads;
    uint32_t software_resets; /* PE 1 -> 0 transitions */
    uint32_t txdr_flushes;    /* ISR.TXE written with 1 */
    uint32_t protocol_errors; /* TXDR without TXIS, RXDR without RXNE, TIMINGR with PE = 1, ... */
    /* internal */
    uint32_t pending_flags; /* raised, not yet visible */
    uint32_t pending_reads; /* ISR reads left before pending_flags appear */
    uint32_t nbytes_left;   /* of the current NBYTES chunk */
    bool reading;
    size_t bytes_out, bytes_in; /* data bytes moved since the last START from idle */
};

struct fake_gpio_port {
    uint32_t regs[11];     /* MODER .. BRR (0x00..0x28) */
    uint32_t external_low; /* pins the outside world pulls low (others read high) */
};

/* Open-drain I2C lines on port B pins 8/9 and the slave on them. */
struct fake_i2c_lines {
    uint32_t sda_release_after_clocks; /* slave holds SDA low until this many SCL rises; 0: free */
    bool scl_held_low;                 /* slave holds SCL low for ever */
    /* observations */
    uint32_t scl_rises;
    uint32_t scl_rises_before_stop; /* SCL rises seen before the first STOP condition */
    uint32_t stops;                 /* SDA rising while SCL high */
    uint32_t starts;                /* SDA falling while SCL high */
    bool last_scl, last_sda;
};

struct fake_systick {
    uint32_t csr, rvr;
    uint32_t cvr_queue[FAKE_CVR_QUEUE]; /* values returned by successive CVR reads */
    size_t cvr_len, cvr_next;
    uint32_t cvr_default; /* once the queue is empty */
    bool pending;         /* ICSR.PENDSTSET */
    uint32_t cvr_reads;
};

struct fake_iwdg {
    uint32_t regs[5];
    uint32_t
        sr_busy_reads; /* SR reads that still show an update in progress; UINT32_MAX: for ever */
    uint32_t kr_log[16];
    size_t kr_len;
    uint32_t sr_reads;
};

/* A time source for the drivers: each now_us() call advances `step_us`. */
struct fake_time {
    uint32_t now;
    uint32_t step_us; /* 0: a stopped clock */
    uint32_t calls;
};

struct fake_stm32 {
    struct fake_i2c i2c;
    struct fake_gpio_port port_a, port_b, port_c;
    struct fake_i2c_lines lines;
    struct fake_systick systick;
    struct fake_iwdg iwdg;
    struct fake_time time;
};

extern struct fake_stm32 fake;

/* Reset every fake: bus idle, lines high, slave at `present_addr`, time at `start_us`. */
void fake_reset(int present_addr, uint32_t start_us);

/* Slave holds SDA low until it has seen `clocks` SCL rises (0: SDA free). */
void fake_set_sda_stuck(uint32_t clocks);
/* Slave holds SCL low for ever. */
void fake_set_scl_stuck(void);

/* Base addresses to put in the drivers' configs. */
uintptr_t fake_i2c_base(void);
uintptr_t fake_port_base(char port);
uintptr_t fake_iwdg_base(void);

/* The fake time as a hal_time. */
struct hal_time fake_time_hal(void);

/* Register of a fake block by offset (for assertions). */
uint32_t fake_i2c_reg(uint32_t offset);
uint32_t fake_port_reg(char port, uint32_t offset);

/* Count of logged events of `kind`; index of the first one at or after `from` (or -1). */
size_t fake_i2c_count(enum fake_i2c_event_kind kind);
int fake_i2c_find(enum fake_i2c_event_kind kind, size_t from);

#endif /* TESTS_BOARDS_FAKE_STM32_H */
