/* Arm semihosting calls for the QEMU images: console, files, exit (semihost.h). */
#include "semihost.h"

#include <string.h>

/* Operation numbers: Semihosting v2.0, table "Semihosting operations". */
enum {
    SYS_OPEN = 0x01,
    SYS_CLOSE = 0x02,
    SYS_WRITE = 0x05,
    SYS_READ = 0x06,
    SYS_GET_CMDLINE = 0x15,
    SYS_EXIT_EXTENDED = 0x20,
};
/* ADP_Stopped_ApplicationExit: the reason code SYS_EXIT_EXTENDED expects. */
#define ADP_STOPPED_APPLICATION_EXIT 0x20026u
/* SYS_OPEN of the special name ":tt" in mode 4 ("w") is the console's stdout. */
#define CONSOLE_NAME       ":tt"
#define CONSOLE_MODE_WRITE 4

static int semihost_call(uint32_t op, void *args) {
    register uint32_t r0 __asm__("r0") = op;
    register void *r1 __asm__("r1") = args;
    __asm__ volatile("bkpt 0xAB" : "+r"(r0) : "r"(r1) : "memory");
    return (int)r0;
}

void semihost_write_stdout(const char *text, size_t len) {
    static int console = -1; /* opened on first use; the only mutable state here */
    if (console < 0) {
        console = semihost_open(CONSOLE_NAME, CONSOLE_MODE_WRITE);
    }
    if (console >= 0) {
        (void)semihost_write(console, text, len);
    }
}

int semihost_open(const char *path, int mode) {
    uint32_t args[3] = {(uint32_t)(uintptr_t)path, (uint32_t)mode, (uint32_t)strlen(path)};
    return semihost_call(SYS_OPEN, args);
}

int semihost_read(int handle, void *buf, size_t len) {
    uint32_t args[3] = {(uint32_t)handle, (uint32_t)(uintptr_t)buf, (uint32_t)len};
    int not_read = semihost_call(SYS_READ, args); /* returns the count NOT read */
    if (not_read < 0 || (size_t)not_read > len) {
        return -1;
    }
    return (int)(len - (size_t)not_read);
}

int semihost_write(int handle, const void *buf, size_t len) {
    uint32_t args[3] = {(uint32_t)handle, (uint32_t)(uintptr_t)buf, (uint32_t)len};
    return semihost_call(SYS_WRITE, args) == 0 ? 0 : -1;
}

void semihost_close(int handle) {
    uint32_t args[1] = {(uint32_t)handle};
    (void)semihost_call(SYS_CLOSE, args);
}

int semihost_cmdline(char *buf, size_t len) {
    uint32_t args[2] = {(uint32_t)(uintptr_t)buf, (uint32_t)len};
    return semihost_call(SYS_GET_CMDLINE, args) == 0 ? 0 : -1;
}

void semihost_exit(int status) {
    uint32_t args[2] = {ADP_STOPPED_APPLICATION_EXIT, (uint32_t)status};
    (void)semihost_call(SYS_EXIT_EXTENDED, args);
    for (;;) {
        /* unreachable under QEMU; a debugger without semihosting halts here */
    }
}
