/*
 * host_sim replay --command ROW:TEXT (docs/reference/tools.md): the commands reach the firmware's
 * own link code (firmware/link.h) as a host's bytes through an in-memory serial port, back to back
 * at 115200 Bd 8N1, starting when row ROW's slot is half over, the instant tof_twin sends them
 * (twin/tool/tof_twin_host.c), so both apply each command between the same two samples. The text is
 * parsed by telemetry/tlm_command_text.h, the one parser of both.
 */
#ifndef HOST_SIM_REPLAY_COMMANDS_H
#define HOST_SIM_REPLAY_COMMANDS_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "firmware/app.h"
#include "firmware/link.h"
#include "firmware/record.h"
#include "sim/sim_clock.h"
#include "telemetry/tlm_frame.h"

#define REPLAY_COMMANDS_MAX 16u

struct replay_commands {
    struct tof_link link;
    const struct sim_clock *clock;
    uint64_t origin_us; /* slot 0 of the replay on the firmware's timeline */
    uint32_t period_us;
    struct {
        uint32_t row;
        uint8_t bytes[TLM_FRAME_MAX];
        size_t len;
    } cmd[REPLAY_COMMANDS_MAX];
    unsigned count;
    unsigned next;        /* the first command not yet on the line */
    uint64_t line_end_ps; /* when the bytes already on the line end */
    uint8_t line[REPLAY_COMMANDS_MAX * TLM_FRAME_MAX];
    uint64_t line_at_ps[REPLAY_COMMANDS_MAX * TLM_FRAME_MAX]; /* each byte's stop bit end */
    size_t line_len, line_read;
    struct tlm_decoder answers;
    uint32_t sent, acked;
};

/* Parse `arg` ("ROW:TEXT") and add it, in order. NULL, or a message naming what is wrong. */
const char *replay_commands_add(struct replay_commands *c, const char *arg);

/* Start the link on `app` (after tof_app_init and the calibration's boot, whose state is
 * `cal_state`), with the replay's record storage `records` (the flight unit's: save,
 * write-calibration and re-zero keep what they write there), slot 0 at `origin_us`, rows
 * `period_us` apart, time from `clock`. */
void replay_commands_start(struct replay_commands *c, struct tof_app *app,
                           struct tof_record_store *records, int cal_state,
                           const struct sim_clock *clock, uint64_t origin_us, uint32_t period_us);

/* After each main-loop iteration: the bytes due on the line, then the link's poll (as the
 * flight image's service poll). */
void replay_commands_poll(struct replay_commands *c);

#endif /* HOST_SIM_REPLAY_COMMANDS_H */
