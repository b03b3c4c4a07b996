/* The trace v1 reader's error messages, built without stdio (trace_v1_impl.h). */
#include <string.h>

#include "trace_v1_impl.h"

struct trace_msg trace_msg_begin(struct trace_v1_reader *r, uint32_t line, uint32_t col) {
    r->err.line = line;
    r->err.col = col;
    r->err.msg[0] = '\0';
    return (struct trace_msg){.s = r->err.msg, .len = 0, .cap = sizeof r->err.msg};
}

static void put(struct trace_msg *m, char c) {
    if (m->len + 1u < m->cap) {
        m->s[m->len++] = c;
        m->s[m->len] = '\0';
    }
}

void trace_msg_str(struct trace_msg *m, const char *s) {
    for (size_t i = 0; s[i] != '\0' && m->len + 1u < m->cap; ++i) {
        put(m, s[i]);
    }
}

void trace_msg_u64(struct trace_msg *m, uint64_t v) {
    char digits[20];
    unsigned n = 0;
    do {
        digits[n++] = (char)('0' + (int)(v % 10u));
        v /= 10u;
    } while (v != 0u && n < sizeof digits);
    while (n > 0u) {
        put(m, digits[--n]);
    }
}

void trace_msg_quote(struct trace_msg *m, const char *s, size_t len) {
    const size_t keep = 40u;
    for (size_t i = 0; i < len && i < keep; ++i) {
        const unsigned char c = (unsigned char)s[i];
        put(m, (c >= 0x20u && c < 0x7fu) ? (char)c : '?');
    }
    if (len > keep) {
        trace_msg_str(m, "...");
    }
}

int trace_msg_fail(struct trace_v1_reader *r) {
    r->state = -1;
    return -1;
}

int trace_v1_fail(struct trace_v1_reader *r, uint32_t line, uint32_t col, const char *what) {
    struct trace_msg m = trace_msg_begin(r, line, col);
    trace_msg_str(&m, what);
    return trace_msg_fail(r);
}

int trace_v1_fail_q(struct trace_v1_reader *r, uint32_t line, uint32_t col, const char *before,
                    const char *s, size_t len, const char *after) {
    struct trace_msg m = trace_msg_begin(r, line, col);
    trace_msg_str(&m, before);
    trace_msg_quote(&m, s, len);
    trace_msg_str(&m, after);
    return trace_msg_fail(r);
}
