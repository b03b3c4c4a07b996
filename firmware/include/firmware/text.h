/*
 * Integer-only text formatting for logs and estimate output. The same bytes
 * come out on every target (host_sim, QEMU, MCU) because no float and no libc
 * printf is involved.
 */
#ifndef FIRMWARE_TEXT_H
#define FIRMWARE_TEXT_H

#include <stddef.h>
#include <stdint.h>

/* A bounded output buffer; `overflow` is set (and output stops) when it is full. */
struct tof_text {
    char *buf;
    size_t cap; /* bytes available, including room for the terminating NUL */
    size_t len;
    int overflow;
};

/* Start writing into `buf` of `cap` bytes (cap >= 1); the text is always NUL-terminated. */
void tof_text_init(struct tof_text *t, char *buf, size_t cap);

/* Append a NUL-terminated string. */
void tof_text_str(struct tof_text *t, const char *s);

/* Append a signed decimal integer. */
void tof_text_i64(struct tof_text *t, int64_t v);

/* Append an unsigned decimal integer. */
void tof_text_u64(struct tof_text *t, uint64_t v);

/*
 * Append `v / 10^decimals` as a decimal fraction with exactly `decimals`
 * digits after the point (0..9), e.g. (-1500, 3) -> "-1.500".
 */
void tof_text_fixed(struct tof_text *t, int64_t v, unsigned decimals);

#endif /* FIRMWARE_TEXT_H */
