/* Integer-only text formatting, the same bytes on every target (firmware/text.h). */
#include "firmware/text.h"

static void put(struct tof_text *t, char c) {
    if (t->len + 1u < t->cap) {
        t->buf[t->len++] = c;
        t->buf[t->len] = '\0';
    } else {
        t->overflow = 1;
    }
}

void tof_text_init(struct tof_text *t, char *buf, size_t cap) {
    t->buf = buf;
    t->cap = cap;
    t->len = 0;
    t->overflow = 0;
    if (cap > 0u) {
        buf[0] = '\0';
    } else {
        t->overflow = 1;
    }
}

void tof_text_str(struct tof_text *t, const char *s) {
    for (size_t i = 0; i < t->cap && s[i] != '\0'; ++i) { /* bounded by the buffer */
        put(t, s[i]);
    }
}

/* Write `digits` digits of v (zero-padded) or, with digits == 0, as many as needed. */
static void put_digits(struct tof_text *t, uint64_t v, unsigned digits) {
    char tmp[20]; /* 2^64 - 1 has 20 digits */
    unsigned n = 0;
    do {
        tmp[n++] = (char)('0' + (int)(v % 10u));
        v /= 10u;
    } while ((v != 0u || n < digits) && n < sizeof tmp);
    while (n > 0u) {
        put(t, tmp[--n]);
    }
}

void tof_text_u64(struct tof_text *t, uint64_t v) {
    put_digits(t, v, 0);
}

void tof_text_i64(struct tof_text *t, int64_t v) {
    if (v < 0) {
        put(t, '-');
        put_digits(t, (uint64_t)0 - (uint64_t)v, 0); /* exact for INT64_MIN too */
    } else {
        put_digits(t, (uint64_t)v, 0);
    }
}

void tof_text_fixed(struct tof_text *t, int64_t v, unsigned decimals) {
    static const uint64_t pow10[10] = {1u,      10u,      100u,      1000u,      10000u,
                                       100000u, 1000000u, 10000000u, 100000000u, 1000000000u};
    if (decimals > 9u) {
        t->overflow = 1; /* outside the contract: flag it rather than print something else */
        return;
    }
    uint64_t mag = v < 0 ? (uint64_t)0 - (uint64_t)v : (uint64_t)v;
    if (v < 0) {
        put(t, '-');
    }
    put_digits(t, mag / pow10[decimals], 0);
    if (decimals > 0u) {
        put(t, '.');
        put_digits(t, mag % pow10[decimals], decimals);
    }
}
