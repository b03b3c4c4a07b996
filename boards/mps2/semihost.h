/*
 * Arm semihosting calls (Arm "Semihosting for AArch32 and AArch64", v2.0):
 * on M-profile the call is `bkpt 0xAB` with the operation in r0 and a pointer
 * to the argument block in r1; QEMU answers with -semihosting-config enable=on.
 */
#ifndef BOARDS_MPS2_SEMIHOST_H
#define BOARDS_MPS2_SEMIHOST_H

#include <stddef.h>
#include <stdint.h>

/* Write `len` bytes to the host's stdout. */
void semihost_write_stdout(const char *text, size_t len);

/* Open `path` ("r" = 0, "w" = 4 in SYS_OPEN mode numbers); returns a handle >= 0, or -1. */
int semihost_open(const char *path, int mode);

/* Read up to `len` bytes; returns the number read (0 at end of file), or -1. */
int semihost_read(int handle, void *buf, size_t len);

/* Write `len` bytes; returns 0 when all were written, -1 otherwise. */
int semihost_write(int handle, const void *buf, size_t len);

/* Close a handle. */
void semihost_close(int handle);

/* Copy the command line QEMU was given (-append) into buf; returns 0 or -1. */
int semihost_cmdline(char *buf, size_t len);

/* End the QEMU process with `status` as its exit code (SYS_EXIT_EXTENDED). */
__attribute__((noreturn)) void semihost_exit(int status);

#define SEMIHOST_MODE_READ_BINARY  1 /* "rb" */
#define SEMIHOST_MODE_WRITE_BINARY 5 /* "wb" */

#endif /* BOARDS_MPS2_SEMIHOST_H */
