/*
 * Watchdog interface: the application kicks it only after a healthy main-loop
 * iteration (one that finished within its time budget).
 */
#ifndef HAL_WATCHDOG_H
#define HAL_WATCHDOG_H

struct hal_watchdog_ops {
    /* Reload the watchdog counter. */
    void (*kick)(void *ctx);
};

struct hal_watchdog {
    const struct hal_watchdog_ops *ops; /* NULL: the board has no watchdog */
    void *ctx;
};

#endif /* HAL_WATCHDOG_H */
