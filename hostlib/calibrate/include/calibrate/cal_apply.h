/*
 * A replay's head calibration (docs/reference/trace-format.md, docs/reference/tools.md), for
 * host_sim replay and the twin: from --calibration HEAD.cal (which wins), the trace's
 * calibration=FILE (relative to the trace), its inline keys, or none (uncalibrated); handed to the
 * firmware the way the flight unit gets it, as record section 2 (firmware/calibration_record.h)
 * preloaded into record storage (sim/sim_flash.h, whose pages the twin copies into the image's
 * flash) that the firmware's own boot then reads.
 */
#ifndef CALIBRATE_CAL_APPLY_H
#define CALIBRATE_CAL_APPLY_H

#include <stdbool.h>
#include <stddef.h>

#include "firmware/config.h"
#include "firmware/record.h"
#include "sim/sim_flash.h"
#include "trace/trace_v1.h"

/* What a HEAD.cal says it was made in (its keys head_id, distance_mode, timing_budget_ms,
 * as tools/tof_telemetry.py --read-cal writes them, and part_id_A..part_id_D, the parts' NVM
 * identities, docs/how-to/calibrate-a-head.md): each used when present. */
struct cal_apply_binding {
    bool has_head, has_mode, has_budget, has_arm;
    uint32_t head_id;
    int32_t arm_um; /* the arm_mm key, in um */
    uint8_t mode;   /* enum vl53_distance_mode */
    uint16_t budget_ms;
    uint64_t part_id[4]; /* A..D; 0: the key is absent (the record binds no part) */
};

struct cal_apply {
    struct trace_v1_cal cal;          /* calibrated false: an uncalibrated head */
    struct cal_apply_binding made_in; /* from a HEAD.cal's keys (none for trace keys) */
    char source[320];                 /* where it came from, for the summary and messages */
};

/* The calibration of this replay: `option` (--calibration, NULL: none), else the trace's
 * keys (`meta`, of the trace at `trace_path`). 0, or -1 after a message on stderr naming
 * the file, line and what, after `prog` ("host_sim replay", "tof_twin"). */
int cal_apply_resolve(const char *prog, const char *option, const struct trace_v1_meta *meta,
                      const char *trace_path, struct cal_apply *out);

/* A HEAD.cal at `path` in the trace reader's integers, and what it says it was made in
 * (`made_in`, may be NULL). 0, or -1 with the message in err. */
int cal_apply_load(const char *path, struct trace_v1_cal *out, struct cal_apply_binding *made_in,
                   char *err, size_t errlen);

/* The record storage's two pages of 2 KB (the flight unit's, boards/stm32/stm32_flash.h). */
#define CAL_APPLY_PAGE_SIZE 2048u

/* Record storage (`flash`: two CAL_APPLY_PAGE_SIZE pages, erased, or a copy of `pages_in`
 * when not NULL) holding `cal`'s section made in `cfg`'s configuration and arm (each part,
 * and the arm, `made_in` states, when not NULL, instead: the boot then refuses what the flight unit
 * would) in place of any calibration there (every other section kept; nothing written for an
 * uncalibrated head), and a store over it for the firmware's boot. 0, or -1 (said on stderr). */
int cal_apply_preload(const struct trace_v1_cal *cal, const struct tof_app_config *cfg,
                      const struct cal_apply_binding *made_in, const uint8_t *pages_in,
                      struct sim_flash *flash, struct tof_record_store *store);

/* The firmware's calibration_head of `cal` (the same integers). */
void cal_apply_head(const struct trace_v1_cal *cal, struct calibration_head *out);

#endif /* CALIBRATE_CAL_APPLY_H */
