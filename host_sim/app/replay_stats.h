/*
 * host_sim replay's statistics: each estimator's errors against the trace's truth, its
 * statuses and reasons, the calibration of its sd, and the Cramér-Rao bound of each
 * tumbling window from the window's own readings. Pure arithmetic: no I/O.
 */
#ifndef HOST_SIM_REPLAY_STATS_H
#define HOST_SIM_REPLAY_STATS_H

#include <math.h>
#include <stdbool.h>
#include <stdint.h>

#include "estimator/attitude.h"
#include "scene/row.h"

/* "No value" in tables and JSON (printed as nan / null). */
#define NO_VALUE ((double)NAN)

/* Bits of the why set that are counted in the report: the per-sensor and window ones
 * (0..22) and the reason bits (32..63). */
#define WHY_BITS 64u

/* Per-estimator error statistics. */
struct err_stats {
    uint64_t n_alpha, n_beta;
    double sum2_alpha, sum_abs_alpha, max_alpha;
    double sum2_beta, sum_abs_beta, max_beta;
    uint32_t status_count[3]; /* ok, degraded, invalid */
};

/* Calibration of one estimator's sd on one axis against the truth: answered
 * rows with truth, those within 3 sd and beyond 6 sd, and Σerr², Σsd². */
struct calib_axis {
    uint64_t n, within3, beyond6;
    double sum2_err, sum2_sd;
};

/* Per-sensor sums over a window's valid readings, for its Cramér-Rao bound. */
struct window_truth {
    uint32_t n[4];
    double sum[4], sum2[4];
};

struct replay_stats {
    struct err_stats est[ATTITUDE_EST_COUNT];
    uint64_t estimates;
    bool truth_seen;
    struct window_truth win;
    double crb_sum2_alpha, crb_sum2_beta;
    uint64_t crb_windows;
    double last_crb_alpha, last_crb_beta; /* bound of the window just closed (NaN: none) */
    uint32_t unflagged_wrong[ATTITUDE_EST_COUNT];
    struct calib_axis calib[ATTITUDE_EST_COUNT][2]; /* α, β */
    uint32_t why_count[ATTITUDE_EST_COUNT][WHY_BITS];
};

/* Accounts one trace row as it becomes a sample; window_end: it ends a tumbling window
 * (its bound is computed with arm_mm). */
void replay_stats_sample(struct replay_stats *s, const struct scene_row *row, bool window_end,
                         double arm_mm);

/* Accounts one estimate of every estimator against row, the row it belongs to; sliding:
 * windows slide (no window bound to compare with). */
void replay_stats_estimate(struct replay_stats *s, const struct scene_row *row,
                           const struct attitude_output *out, bool sliding);

/* sqrt(sum2 / n), or NO_VALUE when n is 0. */
double replay_rms(double sum2, uint64_t n);

/* k / n, or NO_VALUE when n is 0. */
double replay_share(uint64_t k, uint64_t n);

/* rms err / rms sd of an axis, or NO_VALUE. */
double replay_calib_ratio(const struct calib_axis *c);

/* The answered (ok + degraded) share of an estimator's estimates, or NO_VALUE. */
double replay_answered(const struct err_stats *s);

#endif /* HOST_SIM_REPLAY_STATS_H */
