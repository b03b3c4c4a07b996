/*
 * Per-sensor health state machine of the fault manager.
 *
 *   HEALTHY --error--> SUSPECT --errors/silence/trouble too long--> LOST --reinit--> RECOVERING
 *      ^                  |                                                            |
 *      +---- good --------+  <-------------------- first good reading -----------------+
 *                                    (a failed re-init goes back to LOST and waits a back-off)
 *
 * Trouble: an episode that starts with an error and ends only after a clean stretch
 * (no error for suspect_timeout_ms). One whose errors span at least that long, with at
 * least trouble_errors of them, makes the sensor LOST whether it stayed SUSPECT throughout or
 * flipped between SUSPECT and HEALTHY: a data-ready line stuck high gives a stale read
 * between every two good ones, and only an XSHUT re-init clears it
 * (docs/reference/fault-campaign.md). The error count keeps sporadic bus errors that happen to
 * chain (NACKs at 1 % of transactions) from costing a re-init.
 *
 * Pure logic over events and millisecond timestamps: no I/O. The firmware feeds
 * it what the driver reported and carries out the action it asks for.
 */
#ifndef FIRMWARE_HEALTH_H
#define FIRMWARE_HEALTH_H

#include <stdbool.h>
#include <stdint.h>

enum tof_health_state {
    TOF_HEALTH_HEALTHY = 0,
    TOF_HEALTH_SUSPECT = 1,
    TOF_HEALTH_LOST = 2,
    TOF_HEALTH_RECOVERING = 3,
};

/* Thresholds, part of the firmware's const configuration. */
struct tof_health_config {
    uint8_t errors_to_lost;       /* consecutive failed reads that make a sensor LOST (>= 1) */
    uint8_t good_to_healthy;      /* consecutive good reads that clear SUSPECT (>= 1) */
    uint32_t silence_to_lost_ms;  /* no reading for this long: LOST (> one measurement period) */
    uint32_t reinit_backoff_ms;   /* wait after a failed re-init before the next attempt */
    uint32_t recovery_timeout_ms; /* RECOVERING without a good reading this long: LOST again */
    uint32_t suspect_timeout_ms;  /* trouble (errors without a clean stretch this long, see
                                     above) whose errors span this long: LOST, so an XSHUT
                                     re-init clears what the sensor cannot */
    uint8_t trouble_errors;       /* ... with at least this many errors in it (>= 1) */
};

struct tof_health {
    enum tof_health_state state;
    uint8_t consecutive_errors;
    uint8_t consecutive_good;
    bool in_trouble;             /* an error since the last clean stretch (see above) */
    uint8_t trouble_error_count; /* errors in the episode (saturating) */
    uint32_t last_good_ms;       /* time of the last good reading (or of entering RECOVERING) */
    uint32_t state_since_ms;     /* time the current state was entered */
    uint32_t next_reinit_ms;     /* LOST: earliest time of the next re-init attempt */
    uint32_t trouble_since_ms;   /* time of the episode's first error */
    uint32_t last_error_ms;      /* time of the last error */
    uint32_t transitions;        /* number of state changes, for telemetry */
    uint32_t losses;             /* number of times the sensor became LOST */
};

/* What the firmware should do for this sensor now. */
enum tof_health_action {
    TOF_HEALTH_ACT_NONE = 0,
    TOF_HEALTH_ACT_REINIT = 1, /* cycle XSHUT and bring the sensor up again */
};

/* Start HEALTHY at `now_ms`. */
void tof_health_init(struct tof_health *h, uint32_t now_ms);

/* A reading arrived and passed the driver's checks. */
void tof_health_on_good(struct tof_health *h, const struct tof_health_config *cfg, uint32_t now_ms);

/* Whom an error concerns: the sensor, or the whole bus (SDA stuck, bus held or
 * arbitration lost), which bus recovery clears and a sensor re-init cannot. */
enum tof_error_scope {
    TOF_ERROR_SENSOR = 0,
    TOF_ERROR_BUS = 1,
    TOF_ERROR_DEVICE = 2, /* the sensor reported its own hardware fault: LOST at once */
};

/* A read or poll failed (bus error, timeout, corrupt data, sensor found reset). Every
 * error counts toward errors_to_lost; only sensor errors count toward trouble. */
void tof_health_on_error(struct tof_health *h, const struct tof_health_config *cfg, uint32_t now_ms,
                         enum tof_error_scope scope);

/* Re-initialization finished: `ok` true enters RECOVERING, false stays LOST with back-off. */
void tof_health_on_reinit_done(struct tof_health *h, const struct tof_health_config *cfg,
                               uint32_t now_ms, bool ok);

/*
 * Periodic check (every main-loop iteration): applies the silence and recovery
 * timeouts and returns the action due now. Wrapping timestamps are handled.
 */
enum tof_health_action tof_health_poll(struct tof_health *h, const struct tof_health_config *cfg,
                                       uint32_t now_ms);

/* True unless LOST: the sensor is polled and its good readings feed the estimator. */
bool tof_health_usable(const struct tof_health *h);

/* Short name of a state ("healthy", "suspect", "lost", "recovering"). */
const char *tof_health_name(enum tof_health_state state);

/* True when `cfg` is consistent (thresholds >= 1, timeouts > 0). */
bool tof_health_config_valid(const struct tof_health_config *cfg);

#endif /* FIRMWARE_HEALTH_H */
