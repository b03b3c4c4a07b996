/*
 * libFuzzer target: the estimator facade (estimator/attitude.h) with arbitrary
 * configurations, then arbitrary ranges, statuses and present flags.
 *
 * Input: one mode byte, a configuration (raw: every field straight from the
 * input, valid or not; guided: every field mapped into its valid range, Q = 0 or
 * Q > 0 by its shift byte), then row commands until the input ends (explicit rows,
 * noisy tilted-plate blocks with flagged and missing readings and spikes, repeats,
 * gaps). Mode byte: bit 0 raw, bit 1 the Kalman filter's process_noise_auto (Q and R
 * learnt from the rows), bit 7 twins: rows are fed to two states that start
 * from different garbage, and every output of both must agree field by field (no
 * dependence on uninitialised state).
 *
 * Properties checked (FUZZ_CHECK aborts with the condition):
 *   - attitude_init accepts exactly the configurations the header calls valid,
 *     and an error names a field that is really invalid;
 *   - an estimate is ready exactly when the window rule of the header says so,
 *     and covers rows last-N+1 .. last;
 *   - per sensor, flagged and missing counts equal what the harness fed in over
 *     the window; used + flagged + missing + rejected = N (window estimators);
 *   - status, reason and validity agree: ok ⇒ every reading used and no reason;
 *     degraded ⇒ a degraded reason that the counts (or a Kalman restart inside
 *     the window) justify; invalid ⇒ an invalid reason and the invalid axes 0;
 *     a disabled estimator is invalid/disabled; the product consensus never
 *     reports no-convergence (the header proves its bound);
 *   - valid angles within ±90°, sigmas >= 0, iteration counts within their caps,
 *     window distances within the readings' range;
 *   - a Kalman "restarted" reason only when the filter restarted inside the window,
 *     and never an ok Kalman estimate across a restart;
 *   - integrity: ok exactly when the why set is empty, never ok from a
 *     window holding a reading of 0, a no-target value or one beyond range_max_mm,
 *     an sd >= 1 beside every value (>= the estimator's own sigma), none beside none;
 *   - oracle: a window of N identical complete valid rows gives consensus answered at
 *     atan((x_C − x_A)/2a) and atan((x_B − x_D)/2a) (±6 µdeg), mean answered at the mean
 *     of the five exact per-row angles, and the paper rule invalid with
 *     "paper-nonpositive-variance" (all covariances are 0).
 *
 * Long run: docs/explanation/reliability.md, "Fuzzing".
 */
#include <stdint.h>
#include <string.h>

#include "estimator/angles.h"
#include "estimator/attitude.h"
#include "fuzz_input.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

#define ROWS_MAX         768u  /* per input, keeps one execution in the millisecond range */
#define SLIDING_WORK_MAX 8192u /* rows x N in sliding mode (each row computes a window) */

struct row {
    uint16_t range[ATTITUDE_SENSORS];
    uint8_t status[ATTITUDE_SENSORS];
    bool present[ATTITUDE_SENSORS];
};

struct harness {
    struct attitude_state st[2];
    unsigned twins; /* states fed: 2 compares them */
    struct attitude_config cfg;
    uint32_t rows;
    uint32_t outputs;
    uint32_t row_limit;
    struct row last;
    bool have_last;
    uint32_t identical_run; /* identical complete valid rows ending at the newest */
    struct row ring[ATTITUDE_WINDOW_MAX];
    bool restarted;             /* the Kalman filter ever restarted */
    uint32_t restart_first_row; /* the restarted filter's first row: the one after the row
                                   during whose push a lock-out restarted it, or that row
                                   itself when the restart came before it (a wrong R guess
                                   found at the last window's end) */
    uint32_t restarts_seen;
};

static struct harness h;

/* --- configuration ---------------------------------------------------------------- */

static bool arm_ok(int32_t a) {
    return a >= 1000 && a <= 1000000;
}
static bool window_ok(uint16_t n) {
    return n >= 2u && n <= ATTITUDE_WINDOW_MAX;
}
static bool mode_ok(enum attitude_window_mode m) {
    return m == ATTITUDE_TUMBLING || m == ATTITUDE_SLIDING;
}
static bool estimators_ok(uint8_t e) {
    return e != 0u && (e & ~ATTITUDE_EST_ALL) == 0u;
}
static bool tolerance_ok(int32_t t) {
    return t >= 1 && t <= 10000000;
}
static bool measurement_noise_ok(const struct attitude_config *c) {
    for (unsigned k = 0; k < ATTITUDE_SENSORS; ++k) {
        if (c->kalman_initial_noise_um2[k] < 83334u) { /* 1/12 mm² */
            return false;
        }
    }
    return true;
}
static bool warmup_ok(uint8_t w) {
    return w >= 1u && w <= 8u;
}

/* The integrity fields (attitude.h, attitude_error_message). */
static bool integrity_ok(const struct attitude_config *c) {
    return c->range_max_mm >= 1u && c->range_max_mm <= 8189u && c->parity_sigmas_q8 >= 256u &&
           c->parity_sigmas_q8 <= 4096u && c->motion_sigmas_q8 >= 256u &&
           c->motion_sigmas_q8 <= 4096u && c->drift_shift >= 1u && c->drift_shift <= 8u &&
           c->period_us >= 1000u && c->period_us <= 10000000u;
}

static bool config_valid(const struct attitude_config *c) {
    return arm_ok(c->arm_um) && window_ok(c->window) && mode_ok(c->mode) &&
           estimators_ok(c->estimators) && tolerance_ok(c->consensus_tolerance_udeg) &&
           c->paper_max_iterations != 0u && measurement_noise_ok(c) &&
           warmup_ok(c->kalman_warmup_rows) && c->kalman_noise_shift <= 8u && integrity_ok(c);
}

/* The field an error names must really be invalid. */
static bool error_names_invalid_field(int err, const struct attitude_config *c) {
    switch (err) {
    case ATTITUDE_ERR_ARM:
        return !arm_ok(c->arm_um);
    case ATTITUDE_ERR_WINDOW:
        return !window_ok(c->window);
    case ATTITUDE_ERR_MODE:
        return !mode_ok(c->mode);
    case ATTITUDE_ERR_ESTIMATORS:
        return !estimators_ok(c->estimators);
    case ATTITUDE_ERR_TOLERANCE:
        return !tolerance_ok(c->consensus_tolerance_udeg);
    case ATTITUDE_ERR_PAPER_ITERATIONS:
        return c->paper_max_iterations == 0u;
    case ATTITUDE_ERR_KALMAN_MEASUREMENT_NOISE:
        return !measurement_noise_ok(c);
    case ATTITUDE_ERR_KALMAN_WARMUP:
        return !warmup_ok(c->kalman_warmup_rows);
    case ATTITUDE_ERR_KALMAN_NOISE_SHIFT:
        return c->kalman_noise_shift > 8u;
    case ATTITUDE_ERR_INTEGRITY:
        return !integrity_ok(c);
    default:
        return false; /* PROCESS_NOISE cannot be invalid for a uint32 field; NULL not passed */
    }
}

static void config_raw(struct fuzz_input *in, struct attitude_config *c) {
    c->arm_um = fuzz_s32(in);
    c->window = fuzz_u16(in);
    c->mode = (enum attitude_window_mode)fuzz_u8(in);
    c->estimators = fuzz_u8(in);
    c->consensus_tolerance_udeg = fuzz_s32(in);
    c->paper_max_iterations = fuzz_u16(in);
    c->paper_consistency_sigmas_q8 = fuzz_u16(in);
    c->gate_sigmas_q8 = fuzz_u16(in);
    c->gate_floor_mm = fuzz_u16(in);
    for (unsigned i = 0; i < KALMAN_STATES; ++i) {
        c->kalman_process_noise_um2[i] = fuzz_u32(in);
    }
    for (unsigned k = 0; k < ATTITUDE_SENSORS; ++k) {
        c->kalman_initial_noise_um2[k] = fuzz_u32(in);
    }
    c->kalman_gate_sigmas_q8 = fuzz_u16(in);
    c->kalman_warmup_rows = fuzz_u8(in);
    c->kalman_noise_shift = fuzz_u8(in);
    c->range_max_mm = fuzz_u16(in);
    c->parity_sigmas_q8 = fuzz_u16(in);
    c->motion_sigmas_q8 = fuzz_u16(in);
    c->offset_stability_um = fuzz_u16(in);
    c->drift_flag_um = fuzz_u16(in);
    c->drift_shift = fuzz_u8(in);
    c->period_us = fuzz_u32(in);
    c->offset_walk_um2_h = fuzz_u32(in);
}

/* Every field inside its valid range, spread over the range. */
static void config_guided(struct fuzz_input *in, struct attitude_config *c) {
    attitude_config_default(c);
    c->arm_um = (int32_t)fuzz_range_u32(in, 1000u, 1000000u);
    c->window = (uint16_t)fuzz_range_u32(in, 2u, ATTITUDE_WINDOW_MAX);
    c->mode = (fuzz_u8(in) & 1u) != 0u ? ATTITUDE_SLIDING : ATTITUDE_TUMBLING;
    c->estimators = (uint8_t)fuzz_range_u32(in, 1u, ATTITUDE_EST_ALL);
    c->consensus_tolerance_udeg = (int32_t)fuzz_range_u32(in, 1u, 10000000u);
    c->paper_max_iterations = (uint16_t)fuzz_range_u32(in, 1u, 1000u);
    c->paper_consistency_sigmas_q8 = fuzz_u16(in);
    c->gate_sigmas_q8 = fuzz_u16(in);
    c->gate_floor_mm = (uint16_t)fuzz_range_u32(in, 0u, 255u);
    const uint8_t q_shift = fuzz_u8(in);
    for (unsigned i = 0; i < KALMAN_STATES; ++i) {
        c->kalman_process_noise_um2[i] = (uint32_t)fuzz_u16(in) << (q_shift % 17u);
    }
    for (unsigned k = 0; k < ATTITUDE_SENSORS; ++k) {
        c->kalman_initial_noise_um2[k] = fuzz_range_u32(in, 83334u, UINT32_MAX);
    }
    c->kalman_gate_sigmas_q8 = fuzz_u16(in);
    c->kalman_warmup_rows = (uint8_t)fuzz_range_u32(in, 1u, 8u);
    c->kalman_noise_shift = (uint8_t)fuzz_range_u32(in, 0u, 8u);
    c->range_max_mm = (uint16_t)fuzz_range_u32(in, 1u, 8189u);
    c->parity_sigmas_q8 = (uint16_t)fuzz_range_u32(in, 256u, 4096u);
    c->motion_sigmas_q8 = (uint16_t)fuzz_range_u32(in, 256u, 4096u);
    c->offset_stability_um = fuzz_u16(in);
    c->drift_flag_um = fuzz_u16(in);
    c->drift_shift = (uint8_t)fuzz_range_u32(in, 1u, 8u);
    c->period_us = fuzz_range_u32(in, 1000u, 10000000u);
    c->offset_walk_um2_h = fuzz_u32(in);
}

/* --- checks of one output ------------------------------------------------------------ */

static bool enabled(enum attitude_estimator e) {
    return (h.cfg.estimators & ATTITUDE_EST_BIT(e)) != 0u;
}

static bool reason_is_degraded(enum attitude_reason r) {
    return r == ATTITUDE_REASON_FLAGGED_DATA || r == ATTITUDE_REASON_SENSOR_MISSING ||
           r == ATTITUDE_REASON_KALMAN_RESTARTED;
}

static bool reason_is_invalid(enum attitude_reason r) {
    return r != ATTITUDE_REASON_NONE && !reason_is_degraded(r) && r < ATTITUDE_REASON_COUNT;
}

static bool angle_ok(int32_t udeg) {
    return udeg >= -FIX_UDEG_90 && udeg <= FIX_UDEG_90;
}

/* A reading no part gives as a measurement: 0, no-target values, beyond the range. */
static bool implausible(uint16_t mm) {
    return mm == 0u || mm > h.cfg.range_max_mm;
}

/* Flagged (non-zero status or implausible) and missing readings of sensor k over the last
 * n rows, from the harness's ring; *bad: some present reading was implausible. */
static void fed_counts(unsigned k, uint16_t n, uint16_t *flagged, uint16_t *missing, bool *bad) {
    *flagged = 0;
    *missing = 0;
    for (uint32_t r = h.rows - n; r < h.rows; ++r) {
        const struct row *row = &h.ring[r % ATTITUDE_WINDOW_MAX];
        if (!row->present[k]) {
            ++*missing;
        } else if (row->status[k] != 0u || implausible(row->range[k])) {
            ++*flagged;
            *bad = *bad || implausible(row->range[k]);
        }
    }
}

static bool restart_inside_window(const struct attitude_output *out) {
    return h.restarted && h.restart_first_row > out->first_row;
}

static void check_estimate(const struct attitude_output *out, enum attitude_estimator which) {
    const struct attitude_estimate *e = &out->est[which];
    const uint16_t n = out->rows;
    FUZZ_CHECK(e->status == ATTITUDE_OK || e->status == ATTITUDE_DEGRADED ||
               e->status == ATTITUDE_INVALID);
    FUZZ_CHECK((unsigned)e->reason < (unsigned)ATTITUDE_REASON_COUNT);
    bool any_unused_reading = false;
    bool sensor_unused = false;
    bool implausible_seen = false;
    for (unsigned k = 0; k < ATTITUDE_SENSORS; ++k) {
        const struct attitude_sensor_counts *c = &e->counts[k];
        uint16_t flagged;
        uint16_t missing;
        fed_counts(k, n, &flagged, &missing, &implausible_seen);
        FUZZ_CHECK(c->flagged == flagged);
        FUZZ_CHECK(c->missing == missing);
        const uint32_t total = (uint32_t)c->used + c->flagged + c->missing + c->rejected;
        if (which == ATTITUDE_EST_KALMAN) {
            FUZZ_CHECK(total <= n); /* rows still buffered for warm-up count as neither */
        } else {
            FUZZ_CHECK(total == n);
        }
        any_unused_reading = any_unused_reading || c->flagged + c->missing + c->rejected != 0u;
        sensor_unused = sensor_unused || c->used == 0u;
    }
    if (!enabled(which)) {
        FUZZ_CHECK(e->status == ATTITUDE_INVALID && e->reason == ATTITUDE_REASON_DISABLED);
    }
    if (which == ATTITUDE_EST_CONSENSUS) {
        FUZZ_CHECK(e->reason != ATTITUDE_REASON_NO_CONVERGENCE); /* a bug by the header's proof */
        FUZZ_CHECK(e->alpha_iterations <= CONSENSUS_PRODUCT_MAX_ITERATIONS);
        FUZZ_CHECK(e->beta_iterations <= CONSENSUS_PRODUCT_MAX_ITERATIONS);
    }
    if (which == ATTITUDE_EST_PAPER) {
        FUZZ_CHECK(e->alpha_iterations <= h.cfg.paper_max_iterations);
        FUZZ_CHECK(e->beta_iterations <= h.cfg.paper_max_iterations);
    }
    if (which == ATTITUDE_EST_KALMAN && enabled(which)) {
        if (e->reason == ATTITUDE_REASON_KALMAN_RESTARTED) {
            FUZZ_CHECK(restart_inside_window(out));
        }
        if (restart_inside_window(out)) {
            FUZZ_CHECK(e->status != ATTITUDE_OK);
        }
    }
    /* ok exactly when nothing is wrong, never from a window holding a reading
     * no part gives as valid; an sd beside every value and none beside no value */
    FUZZ_CHECK((e->status == ATTITUDE_OK) == (e->why == 0u));
    if (implausible_seen) {
        FUZZ_CHECK(e->status != ATTITUDE_OK);
    }
    FUZZ_CHECK(e->alpha_valid ? e->alpha_sd_udeg >= 1 : e->alpha_sd_udeg == 0);
    FUZZ_CHECK(e->beta_valid ? e->beta_sd_udeg >= 1 : e->beta_sd_udeg == 0);
    FUZZ_CHECK(e->distance_valid ? e->distance_sd_um >= 1 : e->distance_sd_um == 0);
    FUZZ_CHECK(e->alpha_sd_udeg >= e->alpha_sigma_udeg && e->beta_sd_udeg >= e->beta_sigma_udeg);
    const attitude_why_t window_bits = ATTITUDE_WHY_PARITY | ATTITUDE_WHY_MOTION |
                                       ATTITUDE_WHY_DRIFT | ATTITUDE_WHY_RECALIBRATE |
                                       ATTITUDE_WHY_UNCALIBRATED;
    switch (e->status) {
    case ATTITUDE_OK:
        FUZZ_CHECK(e->reason == ATTITUDE_REASON_NONE);
        FUZZ_CHECK(e->alpha_valid && e->beta_valid);
        FUZZ_CHECK(!any_unused_reading && !sensor_unused);
        if (which != ATTITUDE_EST_KALMAN) {
            for (unsigned k = 0; k < ATTITUDE_SENSORS; ++k) {
                FUZZ_CHECK(e->counts[k].used == n);
            }
        }
        break;
    case ATTITUDE_DEGRADED:
        FUZZ_CHECK(reason_is_degraded(e->reason));
        FUZZ_CHECK(e->alpha_valid && e->beta_valid);
        if (e->reason == ATTITUDE_REASON_SENSOR_MISSING) {
            FUZZ_CHECK(sensor_unused);
        } else if (e->reason == ATTITUDE_REASON_FLAGGED_DATA) {
            FUZZ_CHECK(any_unused_reading || (e->why & window_bits) != 0u);
        }
        break;
    default:
        FUZZ_CHECK(reason_is_invalid(e->reason));
        FUZZ_CHECK(!(e->alpha_valid && e->beta_valid));
        break;
    }
    if (e->alpha_valid) {
        FUZZ_CHECK(angle_ok(e->alpha_udeg) && e->alpha_sigma_udeg >= 0);
    } else {
        FUZZ_CHECK(e->alpha_udeg == 0 && e->alpha_sigma_udeg == 0);
    }
    if (e->beta_valid) {
        FUZZ_CHECK(angle_ok(e->beta_udeg) && e->beta_sigma_udeg >= 0);
    } else {
        FUZZ_CHECK(e->beta_udeg == 0 && e->beta_sigma_udeg == 0);
    }
    if (e->distance_valid && which != ATTITUDE_EST_KALMAN) {
        FUZZ_CHECK(e->distance_um >= 0 && e->distance_um <= 65535000);
    }
}

/* A window of N identical complete valid rows: the exact answers are known. */
static void check_constant_window(const struct attitude_output *out) {
    const struct row *r = &h.last;
    const int32_t arm = h.cfg.arm_um;
    if (enabled(ATTITUDE_EST_CONSENSUS)) {
        const struct attitude_estimate *e = &out->est[ATTITUDE_EST_CONSENSUS];
        FUZZ_CHECK(e->status != ATTITUDE_INVALID); /* ok unless the integrity objects */
        const int32_t alpha = angles_pair_udeg(r->range[ANGLES_C], r->range[ANGLES_A], arm, 2u);
        const int32_t beta = angles_pair_udeg(r->range[ANGLES_B], r->range[ANGLES_D], arm, 2u);
        FUZZ_CHECK(e->alpha_udeg - alpha <= 6 && alpha - e->alpha_udeg <= 6);
        FUZZ_CHECK(e->beta_udeg - beta <= 6 && beta - e->beta_udeg <= 6);
    }
    if (enabled(ATTITUDE_EST_PAPER)) {
        const struct attitude_estimate *e = &out->est[ATTITUDE_EST_PAPER];
        FUZZ_CHECK(e->status == ATTITUDE_INVALID &&
                   e->reason == ATTITUDE_REASON_PAPER_NONPOSITIVE_VARIANCE);
    }
    if (enabled(ATTITUDE_EST_MEAN)) {
        const struct attitude_estimate *e = &out->est[ATTITUDE_EST_MEAN];
        struct angles_sample s;
        angles_compute(r->range, ANGLES_ALL_SENSORS, arm, &s);
        int64_t sa = 0;
        int64_t sb = 0;
        for (unsigned i = 0; i < ANGLES_PER_AXIS; ++i) {
            sa += s.alpha_udeg[i];
            sb += s.beta_udeg[i];
        }
        FUZZ_CHECK(e->status != ATTITUDE_INVALID);
        FUZZ_CHECK(e->alpha_udeg == (int32_t)fix_div_round_s64(sa, 5));
        FUZZ_CHECK(e->beta_udeg == (int32_t)fix_div_round_s64(sb, 5));
    }
}

static void check_same(const struct attitude_output *a, const struct attitude_output *b) {
    FUZZ_CHECK(a->first_row == b->first_row && a->last_row == b->last_row && a->rows == b->rows);
    for (unsigned i = 0; i < ATTITUDE_EST_COUNT; ++i) {
        const struct attitude_estimate *x = &a->est[i];
        const struct attitude_estimate *y = &b->est[i];
        FUZZ_CHECK(x->status == y->status && x->reason == y->reason);
        FUZZ_CHECK(x->alpha_valid == y->alpha_valid && x->beta_valid == y->beta_valid);
        FUZZ_CHECK(x->distance_valid == y->distance_valid && x->distance_um == y->distance_um);
        FUZZ_CHECK(x->alpha_udeg == y->alpha_udeg && x->beta_udeg == y->beta_udeg);
        FUZZ_CHECK(x->alpha_sigma_udeg == y->alpha_sigma_udeg);
        FUZZ_CHECK(x->beta_sigma_udeg == y->beta_sigma_udeg);
        FUZZ_CHECK(x->alpha_iterations == y->alpha_iterations);
        FUZZ_CHECK(x->beta_iterations == y->beta_iterations);
        FUZZ_CHECK(x->flatness_valid == y->flatness_valid);
        FUZZ_CHECK(x->flatness_residual_um == y->flatness_residual_um);
        FUZZ_CHECK(x->alpha_sd_udeg == y->alpha_sd_udeg && x->beta_sd_udeg == y->beta_sd_udeg);
        FUZZ_CHECK(x->distance_sd_um == y->distance_sd_um && x->why == y->why);
        FUZZ_CHECK(memcmp(x->counts, y->counts, sizeof x->counts) == 0);
    }
}

/* --- rows ------------------------------------------------------------------------------ */

static bool row_complete_valid(const struct row *r) {
    for (unsigned k = 0; k < ATTITUDE_SENSORS; ++k) {
        if (!r->present[k] || r->status[k] != 0u || implausible(r->range[k])) {
            return false;
        }
    }
    return true;
}

static bool rows_equal(const struct row *a, const struct row *b) {
    for (unsigned k = 0; k < ATTITUDE_SENSORS; ++k) {
        if (a->range[k] != b->range[k] || a->status[k] != b->status[k] ||
            a->present[k] != b->present[k]) {
            return false;
        }
    }
    return true;
}

static void push_row(const struct row *r) {
    if (h.rows >= h.row_limit) {
        return;
    }
    const bool same = h.have_last && rows_equal(r, &h.last);
    h.identical_run = row_complete_valid(r) ? (same ? h.identical_run + 1u : 1u) : 0u;
    h.last = *r;
    h.have_last = true;
    h.ring[h.rows % ATTITUDE_WINDOW_MAX] = *r;

    struct attitude_output out[2];
    bool ready[2] = {false, false};
    for (unsigned i = 0; i < h.twins; ++i) {
        memset(&out[i], 0xA5, sizeof out[i]);
        ready[i] = attitude_push_sample(&h.st[i], r->range, r->status, r->present, &out[i]);
    }
    if (h.st[0].kalman.restarts != h.restarts_seen) {
        h.restarts_seen = h.st[0].kalman.restarts;
        h.restarted = true;
        /* the facade counts the filter's rows: 0 after a restart during this row, 1 when
         * this row was the restarted filter's first */
        h.restart_first_row = h.rows + (h.st[0].kalman_rows_since_restart == 0u ? 1u : 0u);
    }
    h.rows++;
    const uint16_t n = h.cfg.window;
    const bool expect = h.cfg.mode == ATTITUDE_TUMBLING ? h.rows % n == 0u : h.rows >= n;
    FUZZ_CHECK(ready[0] == expect && (h.twins == 1u || ready[1] == expect));
    if (!expect) {
        return;
    }
    h.outputs++;
    FUZZ_CHECK(out[0].rows == n && out[0].last_row == h.rows - 1u);
    FUZZ_CHECK(out[0].first_row == h.rows - n);
    if (h.twins == 2u) {
        check_same(&out[0], &out[1]);
    }
    for (unsigned e = 0; e < ATTITUDE_EST_COUNT; ++e) {
        check_estimate(&out[0], (enum attitude_estimator)e);
    }
    if (h.identical_run >= n) {
        check_constant_window(&out[0]);
    }
}

/* Deterministic noise for the plate blocks (xorshift32). */
static uint32_t next_noise(uint32_t *s) {
    uint32_t x = *s;
    x ^= x << 13;
    x ^= x >> 17;
    x ^= x << 5;
    *s = x;
    return x;
}

static uint16_t clamp_range(int32_t v) {
    return (uint16_t)(v < 0 ? 0 : (v > 65535 ? 65535 : v));
}

/* A block of rows of a tilted plate: x_A = d − t_a, x_C = d + t_a, x_B = d + t_b,
 * x_D = d − t_b (docs/explanation/architecture.md with a·tan in mm), uniform noise ±amp, and per
 * sensor occasional flagged, missing or spiked readings. */
static void plate_block(struct fuzz_input *in, uint32_t count) {
    const int32_t d = fuzz_u16(in);
    const int32_t ta = (int8_t)fuzz_u8(in);
    const int32_t tb = (int8_t)fuzz_u8(in);
    const uint32_t amp = fuzz_u8(in) % 16u;
    const uint8_t faults = fuzz_u8(in); /* bits 0-3 flagged, 4-7 missing, per sensor */
    const uint8_t spikes = fuzz_u8(in); /* bits 0-3: sensor spikes now and then */
    const uint8_t status = fuzz_u8(in); /* status code of the flagged readings */
    uint32_t seed = 0x9E3779B9u ^ fuzz_u16(in);
    const int32_t base[ATTITUDE_SENSORS] = {d - ta, d + tb, d + ta, d - tb};
    for (uint32_t i = 0; i < count; ++i) {
        struct row r;
        for (unsigned k = 0; k < ATTITUDE_SENSORS; ++k) {
            const uint32_t z = next_noise(&seed);
            int32_t v = base[k] + (int32_t)(z % (2u * amp + 1u)) - (int32_t)amp;
            if ((spikes >> k & 1u) != 0u && (z >> 20) % 16u == 0u) {
                v += (z >> 24) % 2u != 0u ? 400 : -400;
            }
            r.range[k] = clamp_range(v);
            r.present[k] = !((faults >> (4u + k) & 1u) != 0u && (z >> 8) % 8u == 0u);
            r.status[k] =
                (faults >> k & 1u) != 0u && (z >> 12) % 8u == 0u ? (uint8_t)(status | 1u) : 0u;
        }
        push_row(&r);
    }
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    struct fuzz_input in = fuzz_input_make(data, size);
    memset(&h.cfg, 0, sizeof h.cfg);
    const uint8_t mode = fuzz_u8(&in);
    if ((mode & 1u) != 0u) {
        config_raw(&in, &h.cfg);
    } else {
        config_guided(&in, &h.cfg);
    }
    /* a bool from a bit: any other byte value would be undefined as a bool */
    h.cfg.kalman_process_noise_auto = (mode & 2u) != 0u;
    const bool valid = config_valid(&h.cfg);
    /* The twin state (different starting garbage) on half the inputs: it doubles the cost. */
    h.twins = (mode & 0x80u) != 0u ? 2u : 1u;
    for (unsigned i = 0; i < h.twins; ++i) {
        memset(&h.st[i], i == 0u ? 0x00 : 0xFF, sizeof h.st[i]);
        const int err = attitude_init(&h.st[i], &h.cfg);
        FUZZ_CHECK(attitude_error_message(err) != NULL);
        if (valid) {
            FUZZ_CHECK(err == ATTITUDE_ERR_NONE);
        } else {
            FUZZ_CHECK(err < 0 && error_names_invalid_field(err, &h.cfg));
            FUZZ_CHECK(attitude_error_message(err)[0] != '\0');
            return 0;
        }
    }
    h.rows = 0;
    h.outputs = 0;
    h.have_last = false;
    h.identical_run = 0;
    h.restarted = false;
    h.restarts_seen = 0;
    h.restart_first_row = 0;
    h.row_limit = ROWS_MAX;
    if (h.cfg.mode == ATTITUDE_SLIDING && SLIDING_WORK_MAX / h.cfg.window < h.row_limit) {
        h.row_limit = SLIDING_WORK_MAX / h.cfg.window;
    }

    while (!fuzz_input_done(&in) && h.rows < h.row_limit) {
        const uint8_t op = fuzz_u8(&in);
        const uint32_t count = 1u + fuzz_u8(&in);
        switch (op & 3u) {
        case 0: { /* one explicit row */
            struct row r;
            for (unsigned k = 0; k < ATTITUDE_SENSORS; ++k) {
                r.range[k] = fuzz_u16(&in);
                r.status[k] = fuzz_u8(&in);
            }
            const uint8_t present = fuzz_u8(&in);
            for (unsigned k = 0; k < ATTITUDE_SENSORS; ++k) {
                r.present[k] = (present >> k & 1u) == 0u; /* bit set: missing */
            }
            push_row(&r);
            break;
        }
        case 1:
            plate_block(&in, count);
            break;
        case 2: /* repeat the last row, (1 + op/4) x count times */
            if (h.have_last) {
                const struct row r = h.last;
                for (uint32_t i = 0; i < count * (1u + (op >> 2)); ++i) {
                    push_row(&r);
                }
            }
            break;
        default: { /* a gap: the sensors in the op's high nibble deliver nothing */
            struct row r = h.have_last ? h.last : (struct row){{0}, {0}, {false}};
            for (unsigned k = 0; k < ATTITUDE_SENSORS; ++k) {
                if ((op >> (4u + k) & 1u) != 0u) {
                    r.present[k] = false;
                }
            }
            for (uint32_t i = 0; i < count; ++i) {
                push_row(&r);
            }
            break;
        }
        }
    }
    return 0;
}
