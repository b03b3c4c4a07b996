/*
 * Recorded trace format v1 (docs/reference/trace-format.md, docs/reference/trace-format.md): the
 * one reader, integer C for every target (host_sim, the QEMU replay image, the twin through
 * host_sim's layer).
 *
 *   # tof-trace v1
 *   # arm_mm=30.0
 *   # period_ms=20
 *   t_ms,a_mm,b_mm,c_mm,d_mm,a_st,b_st,c_st,d_st,alpha_deg,beta_deg
 *   0,98,101,102,100,0,0,0,0,1.000,0.000
 *
 * It pulls bytes through the caller's read function into the caller's block buffer, keeps
 * one line (TRACE_LINE_MAX bytes) in the reader and gives one row at a time; no heap, no
 * stdio, no floating point, every loop bounded by the line or the block. It rejects, never
 * repairs: every malformed input ends with a line, a column and a message (the caller adds
 * the file name). Real numbers are read exactly as decimals into fixed point (µdeg, µm);
 * a value with more digits than the unit holds is flagged inexact, with the offset of its
 * text in the line, so a host can convert the text itself.
 */
#ifndef SIM_TRACE_V1_H
#define SIM_TRACE_V1_H

#include <stdbool.h>
#include <stdint.h>

#define TRACE_LINE_MAX    1024u /* bytes per line without the newline; longer is an error */
#define TRACE_MAX_COLUMNS 64u   /* header fields */
#define TRACE_MAX_META    32u   /* "# key=value" lines */
#define TRACE_KEY_MAX     32u   /* bytes of a key, including the terminator */
#define TRACE_VALUE_MAX   128u  /* bytes of a value, including the terminator */
#define TRACE_MSG_MAX     256u  /* bytes of an error message, without "file:line:col: " */
/* The time base when a trace has no period_ms: the scenarios' and the shared
 * recording's 20 ms (docs/reference/trace-format.md). host_sim replay uses the same default. */
#define TRACE_DEFAULT_PERIOD_MS 20u
#define TRACE_TIMING_NOTES      8u /* irregular time stamps kept with their line */
/* Range status of a sensor that gave no reading (the VL53L1 API's "no update" status,
 * VL53L1_RANGESTATUS_NONE, ST UM2356): such a reading has present = false. */
#define TRACE_STATUS_NO_READING 255u

/* Columns the reader knows, in this order. */
enum trace_column {
    TRACE_COL_T_MS,
    TRACE_COL_A_MM,
    TRACE_COL_B_MM,
    TRACE_COL_C_MM,
    TRACE_COL_D_MM,
    TRACE_COL_A_ST,
    TRACE_COL_B_ST,
    TRACE_COL_C_ST,
    TRACE_COL_D_ST,
    TRACE_COL_ALPHA,
    TRACE_COL_BETA,
    TRACE_COL_DISTANCE,
    TRACE_COL_TEMP, /* temp_c: optional, the head's temperature as the unit measured it */
    TRACE_COL_COUNT
};

/* Irregular time stamps: t_ms equal to the previous row's, or more than two periods
 * after it. Not errors (real loggers skip and stall); the replay reports them. */
enum trace_timing_kind { TRACE_TIME_REPEAT = 1, TRACE_TIME_JUMP = 2 };

struct trace_timing_note {
    uint32_t line;
    uint32_t t_ms, prev_t_ms;
    uint8_t kind; /* enum trace_timing_kind */
};

struct trace_timing {
    uint32_t period_ms;    /* the time base checked against: period_ms, else the default */
    bool period_from_meta; /* false: TRACE_DEFAULT_PERIOD_MS, the trace has no period_ms */
    uint64_t repeats;      /* rows whose t_ms equals the previous row's */
    uint64_t jumps;        /* rows more than 2 * period_ms after the previous row */
    uint32_t max_jump_ms;  /* the largest such step, and its line */
    uint32_t max_jump_line;
    unsigned note_count; /* the first TRACE_TIMING_NOTES irregular rows, in line order */
    struct trace_timing_note notes[TRACE_TIMING_NOTES];
};

/* ---- the head's calibration the trace states (docs/reference/trace-format.md, §6a) ----
 * In estimator/calibration.h's integers and bounds (sim/ does not include the estimator;
 * host_sim and the QEMU image check the two agree): offsets and their sd in µm, gains as
 * ppm of deviation from 1, the offset-gain correlation in Q15. */
#define TRACE_CAL_SENSORS           4u
#define TRACE_CAL_OFFSET_MAX_UM     100000 /* CALIBRATION_OFFSET_MAX_UM */
#define TRACE_CAL_GAIN_MAX_PPM      100000 /* CALIBRATION_GAIN_MAX_PPM */
#define TRACE_CAL_UNCAL_GAIN_SD_PPM 17321u /* CALIBRATION_UNCAL_GAIN_SD_PPM */

/* Which calibration keys a trace (or a HEAD.cal) holds: bits of trace_v1_cal.keys. */
enum trace_cal_key {
    TRACE_CAL_KEY_OFFSET = 1u << 0,    /* offset_mm */
    TRACE_CAL_KEY_OFFSET_SD = 1u << 1, /* offset_sd_mm */
    TRACE_CAL_KEY_GAIN = 1u << 2,      /* gain */
    TRACE_CAL_KEY_GAIN_SD = 1u << 3,   /* gain_sd */
    TRACE_CAL_KEY_CORR = 1u << 4,      /* offset_gain_corr (the project's key) */
    TRACE_CAL_KEY_FILE = 1u << 5,      /* calibration=FILE (the path is the key's value) */
    TRACE_CAL_KEY_NONE = 1u << 6,      /* calibration=none */
};

struct trace_v1_cal {
    uint8_t keys;    /* enum trace_cal_key bits seen */
    bool calibrated; /* after the check: the inline keys give a calibration */
    bool has_gain;   /* gain and gain_sd given (else gain 1, sd TRACE_CAL_UNCAL_GAIN_SD_PPM) */
    int32_t offset_um[TRACE_CAL_SENSORS];
    int32_t gain_ppm[TRACE_CAL_SENSORS];
    uint32_t offset_sd_um[TRACE_CAL_SENSORS];
    uint32_t gain_sd_ppm[TRACE_CAL_SENSORS];
    int16_t corr_q15[TRACE_CAL_SENSORS];
    uint32_t line[7]; /* line of each key (bit order above), 0 if absent */
};

/*
 * One key=value of a trace's metadata or of a HEAD.cal (the same keys,
 * docs/reference/calibration-file.md) into `cal`, exactly as decimals (rounded half away from zero
 * to the unit, no floating point): 1 (not a calibration key: nothing done), 0 (read), or -1 with
 * *what and *col (0-based offset in value of what is wrong). Four comma-separated decimals each;
 * offsets within ±100 mm, gains within 0.9..1.1, sd >= 0 (offset sd <= 100 mm, gain sd <= 0.1), the
 * correlation within -1..1; `calibration` is `none` or a file name. A repeated key is the
 * caller's to refuse.
 */
int trace_v1_cal_value(struct trace_v1_cal *cal, const char *key, const char *value, uint32_t line,
                       uint32_t *col, const char **what);

/* After the last key: the keys make a whole (offset_mm with offset_sd_mm, gain with gain_sd,
 * the correlation only with gains; inline keys, `calibration=FILE` and `calibration=none`
 * exclusive). Sets cal->calibrated and the absent gains. 0, or -1 with *what and *line. */
int trace_v1_cal_check(struct trace_v1_cal *cal, const char **what, uint32_t *line);

/* The metadata: every "# key=value" line before the header, arm_mm and period_ms read. */
struct trace_v1_meta {
    int32_t arm_um;     /* required: a in µm, > 0 (saturated at INT32_MAX) */
    bool arm_exact;     /* false: the text has digits below 1 µm or is beyond INT32_MAX µm */
    uint32_t period_ms; /* optional, > 0; 0 when absent */
    struct trace_v1_cal
        cal;        /* the head's calibration keys, checked (docs/reference/trace-format.md) */
    unsigned count; /* every key=value line, arm_mm and period_ms included */
    char key[TRACE_MAX_META][TRACE_KEY_MAX];
    char value[TRACE_MAX_META][TRACE_VALUE_MAX];
    uint32_t line[TRACE_MAX_META]; /* line of each key=value, for messages */
};

/* Truth values of a row (alpha_deg, beta_deg, distance_mm), in TRUTH order. */
enum trace_truth { TRACE_TRUTH_ALPHA, TRACE_TRUTH_BETA, TRACE_TRUTH_DISTANCE, TRACE_TRUTHS };

/* One sample. Sensor order A, B, C, D = 0..3 (docs/explanation/architecture.md). */
struct trace_v1_row {
    uint32_t t_ms;            /* non-decreasing */
    uint16_t range_mm[4];     /* integer millimetres, as VL53 parts report */
    uint8_t status[4];        /* VL53L1X range status, 0 = valid; 0 when the column is absent */
    bool present[4];          /* false: status 255, no reading */
    bool has[TRACE_TRUTHS];   /* the truth column is there and not empty */
    bool exact[TRACE_TRUTHS]; /* the value below is the text's exactly */
    /* alpha, beta in µdeg (|v| <= 90e6), distance in µm (0..65535e3); rounded to the
     * nearest unit (half away from zero) when not exact */
    int32_t truth[TRACE_TRUTHS];
    uint16_t truth_at[TRACE_TRUTHS]; /* offset of the value's text in the reader's line */
    bool temp_present;               /* the temp_c column is there and not empty */
    int16_t temp_cdeg; /* the head's temperature, 0.01 °C (TRACE_TEMP_MIN_C..TRACE_TEMP_MAX_C),
                          rounded half away from zero */
};

/* temp_c beyond these is no measured temperature of a head in service (the VL53L1X operates
 * from −20 to 85 °C, DS12385 §1; the STM32L4's sensor is calibrated to 110 °C, RM0351): an
 * error naming its line and column, never clamped. */
#define TRACE_TEMP_MIN_C (-100)
#define TRACE_TEMP_MAX_C 200

/* Where the bytes come from: up to len bytes into buf; returns the count, 0 at the end,
 * or a negative number on a read error. */
struct trace_v1_input {
    int32_t (*read)(void *ctx, unsigned char *buf, uint32_t len);
    void *ctx;
};

/* The last failure: line and column (1-based) and what. */
struct trace_v1_error {
    uint32_t line, col;
    char msg[TRACE_MSG_MAX];
};

struct trace_v1_reader {
    struct trace_v1_input in;
    unsigned char *block; /* the caller's read buffer */
    uint32_t block_size, block_len, block_pos;
    bool eof;
    char line[TRACE_LINE_MAX + 1u]; /* the current line, NUL-terminated */
    uint32_t line_len, line_no;
    struct trace_v1_meta meta;
    unsigned n_columns;                    /* fields in the header */
    int8_t column_of[TRACE_COL_COUNT];     /* field index of each known column, -1 if absent */
    uint8_t column_use[TRACE_MAX_COLUMNS]; /* per field: its trace_column + 1, 0 if unknown */
    uint32_t header_line;
    uint64_t rows; /* rows returned so far */
    uint32_t last_t_ms;
    uint32_t last_row_line; /* line of the last row returned */
    struct trace_timing timing;
    bool bom;            /* the input began with a UTF-8 byte-order mark (skipped) */
    uint32_t empty_line; /* first empty line seen after the header; 0 = none */
    int state;           /* 0 reading, 1 ended, -1 failed */
    struct trace_v1_error err;
};

/*
 * Starts reading from `in` through block[0..block_size) (both must outlive the reader;
 * block_size >= 1): checks the version line, reads the metadata and the header.
 * Returns 0, or -1 with the failure in r->err.
 */
int trace_v1_open(struct trace_v1_reader *r, struct trace_v1_input in, unsigned char *block,
                  uint32_t block_size);

/*
 * Next sample. Returns 0 with *row filled, 1 after the last sample, or -1 with r->err.
 * After 1 or -1 it keeps returning that. An input with no sample at all is an error
 * ("no samples"), not an empty end.
 */
int trace_v1_next(struct trace_v1_reader *r, struct trace_v1_row *row);

/*
 * After trace_v1_open: the rows that follow are read without their truth columns
 * (alpha_deg, beta_deg, distance_mm: skipped unread, has[] false), for a pass that needs
 * only the readings (host_sim's distance-mode evidence): the truth's decimals are most of
 * a row's parsing. A truth value such a pass skips is still checked by the pass that reads it.
 */
void trace_v1_readings_only(struct trace_v1_reader *r);

/* Value of metadata key (NULL if absent). */
const char *trace_v1_meta(const struct trace_v1_reader *r, const char *key);

/* Line of metadata key (0 if absent), for messages about its value. */
uint32_t trace_v1_meta_line(const struct trace_v1_reader *r, const char *key);

/* True for the characters a metadata key is made of: letters, digits, '_', '-', '.'. */
bool trace_v1_key_char(char c);

/* ---- the parts' distance mode (one policy for host_sim and the QEMU image) ---- */

/* Modes as the trace's distance_mode key states them; SHORT and LONG carry the numbers of
 * enum vl53_distance_mode (the callers, which see both, check it). */
enum trace_mode { TRACE_MODE_UNSTATED = 0, TRACE_MODE_SHORT = 1, TRACE_MODE_LONG = 2 };

/* Readings only the long mode reports: present, in (short_max_mm, long_max_mm]. */
struct trace_mode_evidence {
    uint16_t short_max_mm, long_max_mm; /* set by the caller (the driver's figures) */
    uint64_t count;
    uint32_t first_line; /* line and sensor (0..3) of the first such reading */
    uint8_t first_sensor;
};

/* Counts row's readings in the band; line is the row's (r->last_row_line). */
void trace_mode_evidence_add(struct trace_mode_evidence *ev, const struct trace_v1_row *row,
                             uint32_t line);

/* Why trace_mode_choose chose. */
enum trace_mode_why {
    TRACE_MODE_BY_OPTION,      /* the caller's option */
    TRACE_MODE_BY_TRACE,       /* the trace's distance_mode */
    TRACE_MODE_NOT_READ_AHEAD, /* short: no evidence (the readings were not read ahead) */
    TRACE_MODE_NO_EVIDENCE,    /* short: no reading only long mode reports */
    TRACE_MODE_BY_READINGS,    /* long: such readings, and the period admits long mode */
    TRACE_MODE_NO_BUDGET,      /* short: such readings, but long mode does not fit the period */
};

struct trace_mode_choice {
    enum trace_mode mode; /* SHORT or LONG */
    enum trace_mode_why why;
};

/*
 * The replay's distance mode: the option, else the trace's statement, else long when the
 * evidence holds readings only long mode reports and long_fits (the period admits a
 * long-mode budget), else short. ev NULL: the readings were not read ahead.
 */
struct trace_mode_choice trace_mode_choose(enum trace_mode option, enum trace_mode stated,
                                           const struct trace_mode_evidence *ev, bool long_fits);

#endif /* SIM_TRACE_V1_H */
