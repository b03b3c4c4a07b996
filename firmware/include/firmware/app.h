/*
 * The application entry point every board calls after its own init.
 */
#ifndef FIRMWARE_APP_H
#define FIRMWARE_APP_H

#include "firmware/platform.h"

/* Firmware identity, printed at boot and in status telemetry. */
#define TOF_FW_NAME    "tof-attitude"
#define TOF_FW_VERSION "0.1.0"

/*
 * Run the application on `platform`. Returns the process exit status on
 * targets that can exit (QEMU, host): 0 on success, a negative HAL error
 * otherwise. On an MCU board the caller resets if this ever returns.
 */
int tof_app_main(const struct tof_platform *platform);

/* Write a NUL-terminated line (plus '\n') to the platform log, if it has one. */
void tof_log_line(const struct tof_platform *platform, const char *text);

#endif /* FIRMWARE_APP_H */
