/*
 * Telemetry messages (firmware -> host) and commands (host -> firmware): the
 * C structs, their encoders (struct -> frame) and their parsers (frame ->
 * struct). Every field is validated both ways, so a parsed message re-encodes
 * to exactly the bytes it came from. Payload layouts: docs/reference/telemetry-protocol.md.
 *
 * Fixed point on the wire: angles in int32 micro-degrees, distances in int32
 * micrometres, times in uint32 milliseconds (wraps after 49.7 days).
 */
#ifndef TELEMETRY_TLM_MESSAGES_H
#define TELEMETRY_TLM_MESSAGES_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "telemetry/tlm_frame.h"

/* Version of this protocol, reported in the status message. */
/* 2: the estimate carries its standard deviations and why set (replacing the reason
 * byte), and nacks the firmware's error code. */
/* 3: the health message ends with uart_overruns (148 bytes), the status message with the
 * record state (17 bytes), and the save command (0x88). */
/* 4: the status message ends with the head calibration's state (18 bytes); write- and
 * read-calibration (0x90, 0x91) and the calibration message (0x10). */
/* 5: the status message ends with the arm (22 bytes); set-arm and set-period (0x89, 0x8A). */
/* 6: the status message ends with the calibration's age and its state (27 bytes). */
/* 7: the temperature: the status message ends with the unit's (30 bytes), the estimate with
 * its window's (50 bytes); write-calibration and the calibration message carry the section's
 * version-4 form with the thermal fields (118 bytes). */
#define TLM_PROTOCOL_VERSION 7u

/* Frame types. Commands have the top bit set, so direction shows in a dump. */
enum tlm_type {
    TLM_TYPE_ESTIMATE = 0x01,
    TLM_TYPE_RAW_SAMPLE = 0x02,
    TLM_TYPE_HEALTH = 0x03,
    TLM_TYPE_ACK = 0x04, /* ack (result 0) or nack (result != 0) of a command */
    TLM_TYPE_STATUS = 0x05,
    TLM_TYPE_CALIBRATION = 0x10, /* the answer to read-calibration */
    TLM_TYPE_SET_WINDOW = 0x81,
    TLM_TYPE_SELECT_ESTIMATOR = 0x82,
    TLM_TYPE_START = 0x83,
    TLM_TYPE_STOP = 0x84,
    TLM_TYPE_STATUS_REQUEST = 0x85,
    TLM_TYPE_RAW_STREAM = 0x86,
    TLM_TYPE_SET_PROCESS_NOISE = 0x87,
    TLM_TYPE_SAVE = 0x88,       /* keep the settings in force across resets (the record) */
    TLM_TYPE_SET_ARM = 0x89,    /* the head's arm a (geometry at run time) */
    TLM_TYPE_SET_PERIOD = 0x8A, /* the sample period (rate at run time) */
    /* The head's calibration (0x90 on, clear of the settings' commands): */
    TLM_TYPE_WRITE_CALIBRATION = 0x90, /* a record section 2, saved and put in force */
    TLM_TYPE_READ_CALIBRATION = 0x91,  /* answered by a calibration message */
    TLM_TYPE_REZERO = 0x92,            /* refit the offsets at the latched position */
};

/* Fixed payload length of each type, in bytes. */
#define TLM_LEN_ESTIMATE          50u
#define TLM_LEN_RAW_SAMPLE        17u
#define TLM_LEN_HEALTH            148u
#define TLM_LEN_ACK               4u
#define TLM_LEN_STATUS            30u
#define TLM_LEN_SET_WINDOW        3u
#define TLM_LEN_SELECT_ESTIMATOR  1u
#define TLM_LEN_START             0u
#define TLM_LEN_STOP              0u
#define TLM_LEN_STATUS_REQUEST    0u
#define TLM_LEN_RAW_STREAM        1u
#define TLM_LEN_SET_PROCESS_NOISE 9u
#define TLM_LEN_SAVE              0u
#define TLM_LEN_SET_ARM           4u /* u32 arm_um */
#define TLM_LEN_SET_PERIOD        2u /* u16 period_ms */
/* The protocol's ranges of set-arm and set-period: the estimator's arm range (estimator/
 * attitude.h, ATTITUDE_ERR_ARM) and the VL53L1X inter-measurement period's (vl53/vl53.h:
 * up to 10 s; the shortest a part can run is its distance mode's shortest budget plus 4 ms,
 * which the firmware checks and nacks). */
#define TLM_ARM_MIN_UM    1000u
#define TLM_ARM_MAX_UM    1000000u
#define TLM_PERIOD_MIN_MS 1u
#define TLM_PERIOD_MAX_MS 10000u
/* The calibration travels as the record's section 2 in its version-4 form (firmware/
 * calibration_record.h): u8 id 2, u8 version, u16 length 114, then the 114 bytes. */
#define TLM_CAL_SECTION_ID        2u
#define TLM_CAL_SECTION_LEN       118u
#define TLM_LEN_WRITE_CALIBRATION TLM_CAL_SECTION_LEN
#define TLM_LEN_READ_CALIBRATION  0u
#define TLM_LEN_REZERO            2u /* u16 samples */
#define TLM_REZERO_MIN            10u
#define TLM_REZERO_MAX            5000u
#define TLM_LEN_CALIBRATION       (1u + TLM_CAL_SECTION_LEN) /* state, section */

#define TLM_SENSOR_COUNT    4u /* A, B, C, D; bit i of a sensor mask is sensor i */
#define TLM_SENSOR_MASK_ALL 0x0Fu

/* "No value" marker of an int32 estimate field (angles of an invalid estimate). */
#define TLM_NO_VALUE INT32_MIN

/* A temperature on the wire: u8 known (0 or 1) and i16 centi-degrees Celsius, 0 when not
 * known; within -100..200 degC, the range a trace's temp_c column takes (docs/reference/
 * trace-format.md), as every part of the system accepts one. */
#define TLM_TEMP_MIN_CDEG (-10000)
#define TLM_TEMP_MAX_CDEG 20000

/* Window length limits of the set-window command and the status message. */
#define TLM_WINDOW_MIN 2u
#define TLM_WINDOW_MAX 255u

/* Flags of the set-process-noise command; every other bit is out of range. */
#define TLM_PROCESS_NOISE_AUTO 0x01u /* the filter learns Q (from qd, qt) and R itself */

enum tlm_estimator {
    TLM_ESTIMATOR_CONSENSUS = 0,       /* the product's default */
    TLM_ESTIMATOR_CONSENSUS_PAPER = 1, /* the published weighting rule, as written */
    TLM_ESTIMATOR_KALMAN = 2,
    TLM_ESTIMATOR_MEAN = 3, /* plain average of the five angles */
};
#define TLM_ESTIMATOR_LAST TLM_ESTIMATOR_MEAN

enum tlm_estimate_status {
    TLM_STATUS_OK = 0,       /* every value present and why empty */
    TLM_STATUS_DEGRADED = 1, /* estimated from fewer sensors or flagged data; why says how */
    TLM_STATUS_INVALID = 2,  /* no estimate of at least one angle; why says why */
};
#define TLM_STATUS_LAST TLM_STATUS_INVALID

enum tlm_sensor_health {
    TLM_HEALTH_HEALTHY = 0,
    TLM_HEALTH_SUSPECT = 1,
    TLM_HEALTH_LOST = 2,
    TLM_HEALTH_RECOVERING = 3,
};
#define TLM_HEALTH_LAST TLM_HEALTH_RECOVERING

enum tlm_window_mode {
    TLM_WINDOW_TUMBLING = 0,
    TLM_WINDOW_SLIDING = 1,
};
#define TLM_WINDOW_MODE_LAST TLM_WINDOW_SLIDING

/*
 * One estimate of one estimator (TLM_TYPE_ESTIMATE): the values, one standard deviation
 * of each (the estimator's honest sd: noise, drift, quantisation, motion;
 * docs/explanation/architecture.md section 6) and the reasons for anything not ok. A value that was
 * not estimated and its sd are both TLM_NO_VALUE, never a claimed sd of 0.
 */
struct tlm_estimate {
    uint32_t t_ms;          /* t_ms of the window's last sample */
    uint32_t window_index;  /* k of window k (sliding mode: the sample index) */
    uint8_t estimator;      /* enum tlm_estimator */
    uint8_t status;         /* enum tlm_estimate_status */
    uint8_t sensors_used;   /* sensor mask; TLM_SENSOR_MASK_ALL when status is ok */
    int32_t alpha_udeg;     /* rotation about z */
    int32_t beta_udeg;      /* rotation about y */
    int32_t distance_um;    /* mean distance */
    int32_t flatness_um;    /* x_A + x_C - x_B - x_D; TLM_NO_VALUE if not all four */
    int32_t alpha_sd_udeg;  /* 1 sd of alpha, >= 1; TLM_NO_VALUE exactly when alpha is */
    int32_t beta_sd_udeg;   /* 1 sd of beta, likewise */
    int32_t distance_sd_um; /* 1 sd of the distance, likewise */
    uint64_t why;           /* the estimator's why set, bits unchanged (attitude_why_t,
                               estimator/integrity.h; attitude_why_format() names them); 0 iff ok */
    bool temp_known;        /* the window's last row had a temperature */
    int16_t temp_cdeg;      /* that temperature, 0.01 degC (TLM_TEMP_*); 0 when not known */
};

/* One four-sensor sample (TLM_TYPE_RAW_SAMPLE). Absent sensors carry zeros. */
struct tlm_raw_sample {
    uint32_t t_ms;
    uint16_t range_mm[TLM_SENSOR_COUNT];
    uint8_t range_status[TLM_SENSOR_COUNT]; /* VL53L1X range status, 0 = valid */
    uint8_t present_mask;                   /* sensor mask of readings present */
};

struct tlm_sensor_counters {
    uint32_t comm_errors; /* failed bus transfers addressed to this sensor */
    uint32_t timeouts;    /* data-ready not seen within its budget */
    uint32_t flagged;     /* readings with a non-zero range status */
    uint32_t reinits;     /* re-initialisations through XSHUT */
};

/* I2C bus errors by kind (hal_err.h codes) and recoveries. */
struct tlm_bus_counters {
    uint32_t addr_nack; /* HAL_ERR_ADDR_NACK */
    uint32_t data_nack; /* HAL_ERR_DATA_NACK */
    uint32_t busy;      /* HAL_ERR_BUS_BUSY */
    uint32_t timeout;   /* HAL_ERR_TIMEOUT */
    uint32_t stuck;     /* HAL_ERR_BUS_STUCK */
    uint32_t other; /* any other code (HAL_ERR_DEVICE, other blocks: docs/reference/errors.md) */
    uint32_t recoveries; /* bus recovery sequences run */
};

/* Health and error counters (TLM_TYPE_HEALTH). Counters are cumulative. */
struct tlm_health {
    uint32_t uptime_ms;
    uint8_t sensor_state[TLM_SENSOR_COUNT]; /* enum tlm_sensor_health */
    struct tlm_sensor_counters sensor[TLM_SENSOR_COUNT];
    struct tlm_bus_counters bus;
    uint32_t watchdog_resets;    /* resets caused by the watchdog since power-on */
    uint32_t loop_overruns;      /* main-loop iterations over their time budget */
    uint32_t loop_max_us;        /* longest main-loop iteration seen */
    uint32_t tx_dropped;         /* telemetry frames not sent (UART buffer full) */
    struct tlm_rx_counters link; /* the firmware's command decoder */
    uint32_t uart_overruns;      /* received bytes the UART lost: receiver overruns (ORE) and
                                    bytes that found the receive buffer full */
};

/* Answer to a command (TLM_TYPE_ACK): result 0 is an ack, anything else a nack. */
struct tlm_ack {
    uint8_t echo_seq; /* sequence of the command answered */
    uint8_t command;  /* type of the command answered (any byte, for unknown types) */
    uint8_t result;   /* enum tlm_result */
    int8_t error;     /* the firmware's own negative code behind a refusal, unchanged (an
                         attitude_error for set-window, select-estimator and
                         set-process-noise); 0 when there is none, always 0 in an ack */
};

/* Firmware version and configuration (TLM_TYPE_STATUS). */
struct tlm_status {
    uint8_t fw_major, fw_minor, fw_patch;
    uint32_t uptime_ms;
    uint16_t window_n; /* TLM_WINDOW_MIN..TLM_WINDOW_MAX */
    uint8_t mode;      /* enum tlm_window_mode */
    uint8_t estimator; /* enum tlm_estimator */
    bool running;
    bool raw_stream;
    uint16_t period_ms;  /* sample period, TLM_PERIOD_MIN_MS..TLM_PERIOD_MAX_MS */
    uint8_t record;      /* enum tlm_record_state: the saved settings at boot */
    uint8_t calibration; /* enum tlm_cal_state: the head's calibration at boot */
    uint32_t arm_um;     /* the head's arm a in force, TLM_ARM_MIN_UM..TLM_ARM_MAX_UM */
    uint32_t cal_age_s;  /* the calibration's age now, s (what the estimator's walk counts) */
    uint8_t cal_age;     /* enum tlm_cal_age_state: how that age is known */
    bool temp_known;     /* the unit has a temperature (the last sample's) */
    int16_t temp_cdeg;   /* that temperature, 0.01 degC (TLM_TEMP_*); 0 when not known */
};

/* The status message's `cal_age`: how the calibration's age is known (the values of
 * firmware/cal_age.h's enum tof_cal_age_state). */
enum tlm_cal_age_state {
    TLM_CAL_AGE_NONE = 0,    /* no calibration in force at boot, or no storage: age 0 */
    TLM_CAL_AGE_KEPT = 1,    /* stored across resets, each boot's off allowance added */
    TLM_CAL_AGE_UNKNOWN = 2, /* a calibration stored without an age: counted from its boot */
    TLM_CAL_AGE_FAILED = 3,  /* the storage refused the last entry: counted, not kept */
};
#define TLM_CAL_AGE_STATE_LAST TLM_CAL_AGE_FAILED

/* The status message's `record`: what the firmware found of its saved settings at boot
 * (the values of firmware/record.h's enum tof_record_state). */
enum tlm_record_state {
    TLM_RECORD_NONE = 0,       /* nothing saved: defaults */
    TLM_RECORD_LOADED = 1,     /* the saved settings are in force */
    TLM_RECORD_CORRUPT = 2,    /* damaged, no valid copy: defaults */
    TLM_RECORD_VERSION = 3,    /* a version this firmware does not read: defaults */
    TLM_RECORD_REJECTED = 4,   /* valid, refused by the application: defaults */
    TLM_RECORD_NO_STORAGE = 5, /* the board has no record storage: defaults */
};
#define TLM_RECORD_STATE_LAST TLM_RECORD_NO_STORAGE

/* The status message's `calibration`: what the firmware found of the head's calibration at
 * boot (the values of firmware/calibration_record.h's enum tof_cal_state). Every state but
 * applied leaves the head uncalibrated: no estimate is `ok`. */
enum tlm_cal_state {
    TLM_CAL_NONE = 0,         /* none stored */
    TLM_CAL_APPLIED = 1,      /* this head's, this configuration's: in force */
    TLM_CAL_CORRUPT = 2,      /* no valid record, or values out of range */
    TLM_CAL_VERSION = 3,      /* a version this firmware does not read */
    TLM_CAL_OTHER_HEAD = 4,   /* made on another head */
    TLM_CAL_OTHER_MODE = 5,   /* made in another distance mode */
    TLM_CAL_REJECTED = 6,     /* refused by the estimator */
    TLM_CAL_NO_STORAGE = 7,   /* the board has no record storage */
    TLM_CAL_OTHER_PARTS = 8,  /* made with other parts (a part's NVM identity differs) */
    TLM_CAL_OTHER_BUDGET = 9, /* made at another timing budget */
    TLM_CAL_OTHER_ARM = 10,   /* made at another arm (set-arm since) */
};
#define TLM_CAL_STATE_LAST TLM_CAL_OTHER_ARM

/* The calibration message (TLM_TYPE_CALIBRATION): what the firmware holds. */
struct tlm_calibration {
    uint8_t state; /* enum tlm_cal_state of the boot, or applied after a write */
    /* the stored section in its version-4 form (id 2, version 4, length 114, the bytes), all
     * zero when none is stored; the telemetry checks the header only, the firmware the
     * content */
    uint8_t section[TLM_CAL_SECTION_LEN];
};

/* A decoded telemetry message, tagged by `type`. */
struct tlm_telemetry {
    uint8_t type; /* TLM_TYPE_ESTIMATE .. TLM_TYPE_STATUS */
    union {
        struct tlm_estimate estimate;
        struct tlm_raw_sample raw;
        struct tlm_health health;
        struct tlm_ack ack;
        struct tlm_status status;
        struct tlm_calibration calibration;
    } u;
};

/* A decoded command, tagged by `type`; the firmware applies it. */
struct tlm_command {
    uint8_t type; /* TLM_TYPE_SET_WINDOW .. TLM_TYPE_SET_PROCESS_NOISE */
    union {
        struct {
            uint16_t window_n; /* TLM_WINDOW_MIN..TLM_WINDOW_MAX */
            uint8_t mode;      /* enum tlm_window_mode */
        } set_window;
        uint8_t estimator; /* TLM_TYPE_SELECT_ESTIMATOR: enum tlm_estimator */
        bool raw_enable;   /* TLM_TYPE_RAW_STREAM */
        /* TLM_TYPE_SET_PROCESS_NOISE: the Kalman filter's random-walk intensities in
         * um²/s, i.e. mm²/s with six decimals fixed (1 mm²/s = 1000000), the units of
         * tof_app_config_process_noise() and host_sim's --process-noise QD,QT: */
        struct {
            uint32_t qd_um2_per_s; /* of the mean distance x̄ */
            uint32_t qt_um2_per_s; /* of a·tan α and a·tan β */
            uint8_t flags;         /* TLM_PROCESS_NOISE_* bits */
        } process_noise;
        /* TLM_TYPE_WRITE_CALIBRATION: record section 2 (header id 2, length 114; the
         * firmware checks the version and the content) */
        uint8_t cal_section[TLM_CAL_SECTION_LEN];
        uint16_t rezero_samples; /* TLM_TYPE_REZERO: TLM_REZERO_MIN..TLM_REZERO_MAX */
        uint32_t arm_um;         /* TLM_TYPE_SET_ARM: TLM_ARM_MIN_UM..TLM_ARM_MAX_UM */
        uint16_t period_ms;      /* TLM_TYPE_SET_PERIOD: TLM_PERIOD_MIN_MS..TLM_PERIOD_MAX_MS */
    } u;
};

/* Which message types a decoder accepts. */
#define TLM_ACCEPT_COMMANDS  0x01u /* host -> firmware: the firmware's decoder */
#define TLM_ACCEPT_TELEMETRY 0x02u /* firmware -> host: a host-side decoder */
#define TLM_ACCEPT_ALL       (TLM_ACCEPT_COMMANDS | TLM_ACCEPT_TELEMETRY)

/*
 * Fixed payload length of `type` if it is one of the types in the `accept`
 * mask (TLM_ACCEPT_*), else -1.
 */
int tlm_type_payload_length(uint8_t type, uint8_t accept);

/*
 * The protocol's type table for a decoder accepting the `accept` mask (TLM_ACCEPT_*):
 * tlm_decoder_init(&dec, tlm_message_types(TLM_ACCEPT_COMMANDS)). Static, never NULL.
 */
const struct tlm_type_table *tlm_message_types(uint8_t accept);

/* True if `type` is a command (host -> firmware) type. */
bool tlm_type_is_command(uint8_t type);

/*
 * Encode `msg` as a frame with sequence `seq` into `out` (capacity `cap`).
 * Returns the frame size, or HAL_ERR_INVALID if a field is out of range or
 * inconsistent (see the struct comments) or `cap` is too small.
 */
int tlm_encode_estimate(uint8_t seq, const struct tlm_estimate *msg, uint8_t *out, size_t cap);
/* As tlm_encode_estimate(), for a raw sample. */
int tlm_encode_raw_sample(uint8_t seq, const struct tlm_raw_sample *msg, uint8_t *out, size_t cap);
/* As tlm_encode_estimate(), for a health message. */
int tlm_encode_health(uint8_t seq, const struct tlm_health *msg, uint8_t *out, size_t cap);
/* As tlm_encode_estimate(), for an ack or nack. */
int tlm_encode_ack(uint8_t seq, const struct tlm_ack *msg, uint8_t *out, size_t cap);
/* As tlm_encode_estimate(), for a status message. */
int tlm_encode_status(uint8_t seq, const struct tlm_status *msg, uint8_t *out, size_t cap);

/* A calibration section's header as the protocol checks it: id 2, a version other than 0,
 * length 114 (the version and the content are the firmware's to check); `none_ok` also takes the
 * all-zero section of "none stored". */
bool tlm_cal_section_is_valid(const uint8_t *section, bool none_ok);

/* As tlm_encode_estimate(), for a calibration message. */
int tlm_encode_calibration(uint8_t seq, const struct tlm_calibration *msg, uint8_t *out,
                           size_t cap);
/* As tlm_encode_estimate(), for a command (host side, tests). */
int tlm_encode_command(uint8_t seq, const struct tlm_command *cmd, uint8_t *out, size_t cap);

/*
 * Validate every field of command `frame` and fill `out`. Returns
 * TLM_RESULT_OK, or the nack reason (UNKNOWN_TYPE for a non-command type,
 * BAD_LENGTH, OUT_OF_RANGE), counted in `counters` unless it is NULL.
 */
enum tlm_result tlm_parse_command(const struct tlm_frame *frame, struct tlm_command *out,
                                  struct tlm_rx_counters *counters);

/* As tlm_parse_command(), for a firmware -> host message (host side, tests). */
enum tlm_result tlm_parse_telemetry(const struct tlm_frame *frame, struct tlm_telemetry *out,
                                    struct tlm_rx_counters *counters);

/*
 * One whole estimate frame in, the decoded estimate out: for a host that already cut the
 * stream into frames (the twin, a capture). `bytes` is exactly one frame, sync to CRC
 * (len bytes). TLM_RESULT_OK with *out filled; TLM_RESULT_BAD_LENGTH if it is not one
 * frame of the estimate's length (or the sync is wrong), TLM_RESULT_UNKNOWN_TYPE if it
 * is another type, TLM_RESULT_OUT_OF_RANGE for a bad CRC or a field out of range.
 */
enum tlm_result tlm_decode_estimate(const uint8_t *bytes, size_t len, struct tlm_estimate *out);

#endif /* TELEMETRY_TLM_MESSAGES_H */
