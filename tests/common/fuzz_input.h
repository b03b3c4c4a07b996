/*
 * Consuming a libFuzzer input as typed values, front to back. Once the input
 * is used up every read returns 0 and `fuzz_input_done` turns true, so a
 * harness never reads past the end and short inputs still run to a clean
 * finish (the mutator then learns which bytes matter).
 *
 * The FUZZ_CHECK macro states a property: on a violation it prints the
 * condition with file and line and aborts, which libFuzzer records as a crash
 * together with the input that caused it.
 */
#ifndef FUZZ_INPUT_H
#define FUZZ_INPUT_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>

#define FUZZ_CHECK(cond)                                                                           \
    do {                                                                                           \
        if (!(cond)) {                                                                             \
            fprintf(stderr, "%s:%d: property violated: %s\n", __FILE__, __LINE__, #cond);          \
            abort();                                                                               \
        }                                                                                          \
    } while (0)

struct fuzz_input {
    const uint8_t *data;
    size_t size;
    size_t pos;
};

static inline struct fuzz_input fuzz_input_make(const uint8_t *data, size_t size) {
    struct fuzz_input in = {data, size, 0u};
    return in;
}

static inline bool fuzz_input_done(const struct fuzz_input *in) {
    return in->pos >= in->size;
}

static inline uint8_t fuzz_u8(struct fuzz_input *in) {
    return in->pos < in->size ? in->data[in->pos++] : 0u;
}

/* Multi-byte values are little-endian in the input. */
static inline uint16_t fuzz_u16(struct fuzz_input *in) {
    const uint16_t lo = fuzz_u8(in);
    return (uint16_t)(lo | (uint16_t)((uint16_t)fuzz_u8(in) << 8));
}

static inline uint32_t fuzz_u32(struct fuzz_input *in) {
    const uint32_t lo = fuzz_u16(in);
    return lo | ((uint32_t)fuzz_u16(in) << 16);
}

static inline uint64_t fuzz_u64(struct fuzz_input *in) {
    const uint64_t lo = fuzz_u32(in);
    return lo | ((uint64_t)fuzz_u32(in) << 32);
}

static inline int64_t fuzz_s64(struct fuzz_input *in) {
    return (int64_t)fuzz_u64(in); /* two's complement (C11 6.3.1.3 is implementation-defined; */
                                  /* gcc and clang wrap) */
}

static inline int32_t fuzz_s32(struct fuzz_input *in) {
    return (int32_t)fuzz_u32(in);
}

/* A value in [lo, hi] (hi >= lo), from one to four bytes depending on the span. */
static inline uint32_t fuzz_range_u32(struct fuzz_input *in, uint32_t lo, uint32_t hi) {
    const uint32_t span = hi - lo;
    uint32_t v;
    if (span < 0x100u) {
        v = fuzz_u8(in);
    } else if (span < 0x10000u) {
        v = fuzz_u16(in);
    } else {
        v = fuzz_u32(in);
    }
    return span == UINT32_MAX ? v : lo + v % (span + 1u);
}

#endif /* FUZZ_INPUT_H */
