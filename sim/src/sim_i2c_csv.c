/* One CSV line per I²C transaction (the --i2c-log format of sim_i2c_csv.h). */
#include "sim/sim_i2c_csv.h"

#include "hal/hal_err.h"

struct out {
    char *buf;
    size_t cap;
    size_t len;
    bool full;
};

static void put_char(struct out *o, char c) {
    if (o->len + 1u < o->cap) {
        o->buf[o->len++] = c;
    } else {
        o->full = true;
    }
}

static void put_text(struct out *o, const char *text) {
    for (size_t i = 0; text[i] != '\0' && i < 32u; ++i) {
        put_char(o, text[i]);
    }
}

static void put_hex(struct out *o, const uint8_t *bytes, size_t len) {
    static const char digits[] = "0123456789abcdef";
    for (size_t i = 0; i < len; ++i) {
        put_char(o, digits[bytes[i] >> 4]);
        put_char(o, digits[bytes[i] & 0x0Fu]);
    }
}

static void put_decimal(struct out *o, uint64_t value) {
    char reversed[20];
    size_t n = 0u;
    do {
        reversed[n++] = (char)('0' + (int)(value % 10u));
        value /= 10u;
    } while (value != 0u && n < sizeof reversed);
    while (n > 0u) {
        put_char(o, reversed[--n]);
    }
}

size_t sim_i2c_csv_line(const struct sim_i2c_transaction *t, char *buf, size_t cap) {
    if (buf == NULL || cap == 0u) {
        return 0u;
    }
    struct out o = {buf, cap, 0u, false};
    const uint8_t addr = (uint8_t)(t->addr7 & 0x7Fu);
    put_decimal(&o, t->start_us);
    put_text(&o, ",0x");
    put_hex(&o, &addr, 1u);
    put_char(&o, ',');
    put_hex(&o, t->tx, t->tx != NULL ? t->tx_len : 0u);
    put_char(&o, ',');
    put_hex(&o, t->rx, (t->rx != NULL && t->result == HAL_OK) ? t->rx_len : 0u);
    put_char(&o, ',');
    put_text(&o, t->result == HAL_OK ? "ok" : hal_err_name(t->result));
    put_char(&o, '\n');
    if (o.full) {
        buf[0] = '\0';
        return 0u;
    }
    buf[o.len] = '\0';
    return o.len;
}
