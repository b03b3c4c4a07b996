#include "firmware/app.h"

#include <string.h>

void tof_log_line(const struct tof_platform *platform, const char *text) {
    if (platform->log.ops == NULL || platform->log.ops->write == NULL) {
        return;
    }
    platform->log.ops->write(platform->log.ctx, text, strlen(text));
    platform->log.ops->write(platform->log.ctx, "\n", 1);
}

int tof_app_main(const struct tof_platform *platform) {
    tof_log_line(platform, TOF_FW_NAME " " TOF_FW_VERSION);
    tof_log_line(platform, platform->board_name);
    return 0;
}
