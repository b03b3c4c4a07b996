/*
 * Log sink: one line of text at a time (UART on a board, semihosting under
 * QEMU, stderr on the host). No formatting here; callers build the text.
 */
#ifndef HAL_LOG_H
#define HAL_LOG_H

#include <stddef.h>

struct hal_log_ops {
    /* Write `len` bytes of `text` (no terminator needed). Never blocks unboundedly. */
    void (*write)(void *ctx, const char *text, size_t len);
};

struct hal_log {
    const struct hal_log_ops *ops;
    void *ctx;
};

#endif /* HAL_LOG_H */
