/*
 * QEMU MPS2 board (mps2-an386: Cortex-M4, mps2-an385: Cortex-M3): the log goes
 * to the host's stdout and main()'s status becomes QEMU's exit code, both
 * through semihosting.
 */
#include "board.h"
#include "firmware/app.h"
#include "semihost.h"

static void semihost_log_write(void *ctx, const char *text, size_t len) {
    (void)ctx;
    semihost_write_stdout(text, len);
}

static const struct hal_log_ops semihost_log_ops = {.write = semihost_log_write};

int main(void) {
    const struct tof_platform platform = {
        .board_name = BOARD_NAME,
        .log = {.ops = &semihost_log_ops, .ctx = 0},
    };
    return tof_app_main(&platform);
}

void board_exit(int status) {
    /* A negative HAL error becomes a non-zero exit code QEMU passes to its caller. */
    semihost_exit(status < 0 ? -status : status);
}

void board_fault(const char *what) {
    static const char prefix[] = "FAULT: ";
    semihost_write_stdout(prefix, sizeof prefix - 1u);
    const char *end = what;
    for (unsigned n = 0; *end != '\0' && n < 64u; ++n) {
        ++end;
    }
    semihost_write_stdout(what, (size_t)(end - what));
    semihost_write_stdout("\n", 1);
    semihost_exit(128);
}
