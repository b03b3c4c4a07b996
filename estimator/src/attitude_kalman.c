/* The facade's Kalman policy: restarts, row outcomes, noise learning, the lag check. */
/* The lag check compares the filter's estimate with the window's product estimate. */
#include <string.h>

#include "attitude_internal.h"

/* Kalman outcomes kept per row in window_row.aux: low nibble used, high rejected. */
#define AUX_USED(m)     ((uint8_t)((m)&0x0Fu))
#define AUX_REJECTED(m) ((uint8_t)(((m) >> 4) & 0x0Fu))
#define AUX_MAKE(u, r)  ((uint8_t)(((u)&0x0Fu) | (((r)&0x0Fu) << 4)))

/* v² in Q32 mm² for v in Q32 mm, saturating. */
static fix_q32_t square_mm2(fix_q32_t v) {
    return fix_s128_to_s64(fix_s128_shr_round(fix_s128_mul(v, v), FIX_Q32_SHIFT), NULL);
}

/* After a restart the filter's estimate no longer contains the window's earlier
 * readings: they stop counting as used (their rejections still count). */
static void forget_kalman_used(struct attitude_state *st) {
    for (uint16_t age = 0; age < window_fill(&st->window); ++age) {
        struct window_row *row = window_row_at(&st->window, age);
        row->aux = AUX_MAKE(0u, AUX_REJECTED(row->aux));
    }
}

/* A restart while processing the newest row: the row count restarts with it, and the lag
 * learnt against the windows is the old filter's. */
static void note_kalman_restart(struct attitude_state *st) {
    forget_kalman_used(st);
    st->kalman_rows_since_restart = 0;
    st->kalman_lag_blocks = 0;
    (void)memset(st->kalman_lag_udeg, 0, sizeof st->kalman_lag_udeg);
    (void)memset(st->kalman_lag_var_udeg2, 0, sizeof st->kalman_lag_var_udeg2);
}

/* Writes the Kalman outcomes of the rows just processed into their ring rows (newest: the
 * row just pushed, or NULL to look it up). */
static void record_kalman_rows(struct attitude_state *st, const struct kalman_rows *rows,
                               struct window_row *newest) {
    if (rows->count == 1u && newest != NULL) { /* the common row */
        newest->aux = AUX_MAKE(rows->used[0], rows->rejected[0]);
        return;
    }
    for (unsigned i = 0; i < rows->count; ++i) {
        struct window_row *row = window_row_at(&st->window, (uint16_t)(rows->count - 1u - i));
        if (row != NULL) {
            row->aux = AUX_MAKE(rows->used[i], rows->rejected[i]);
        }
    }
}

void attitude_kalman_restart(struct attitude_state *st) {
    st->kalman_restart_due = false;
    kalman_reset(&st->kalman);
    st->kalman.restarts++;
    note_kalman_restart(st); /* before this row: it is the filter's first */
}

void attitude_kalman_push_row(struct attitude_state *st, const uint16_t ranges[ATTITUDE_SENSORS],
                              uint8_t valid_mask, struct window_row *newest) {
    const uint32_t restarts = st->kalman.restarts;
    struct kalman_rows rows;
    kalman_push_row(&st->kalman, ranges, valid_mask, &rows);
    record_kalman_rows(st, &rows, newest);
    if (st->kalman.restarts != restarts) {
        note_kalman_restart(st);
    }
}

void attitude_kalman_flush(struct attitude_state *st) {
    const uint32_t restarts = st->kalman.restarts;
    struct kalman_rows rows;
    kalman_flush(&st->kalman, &rows);
    record_kalman_rows(st, &rows, NULL);
    if (st->kalman.restarts != restarts) {
        note_kalman_restart(st);
    }
}

void attitude_kalman_learn_noise(struct attitude_state *st) {
    const struct window_stats *w = &st->stats;
    bool guess_off = false;
    for (unsigned k = 0; k < ATTITUDE_SENSORS; ++k) {
        guess_off = kalman_track_noise(&st->kalman, k, w->sensor[k].var_mm2, w->sensor[k].used) ||
                    guess_off;
    }
    /* A filter that outlives its window (sliding, or tracking with Q > 0) weighed and
     * gated the rows so far with the configured R; when the first window's noise
     * says that guess was off by more than 2x, those rows are over- or under-weighted
     * for good (a VL53L1X at 2.5 m read 7.3 mm against the 2 mm guess: its first 100
     * rows, gated at 10 mm, counted 13x and held the estimate 1.8° off): start again
     * with the learnt R. A tumbling filter with Q = 0 restarts every window anyway. */
    if (guess_off && (st->cfg.mode == ATTITUDE_SLIDING || st->kalman.process_noise)) {
        st->kalman_restart_due = true; /* before the next row: this estimate stands */
    }
}

/* The comparison of the filter with the window on one axis: their difference (µdeg) and
 * the noise variance of that difference (µdeg²). */
struct kalman_cmp {
    bool valid;
    int64_t delta;
    int64_t var;
};

/* A filter that outlives its windows (sliding mode, or tracking with Q > 0) can lag a
 * moving plate by more than its window; one restarted with each window (tumbling, Q = 0)
 * answers from rows the window's gate may have dropped (garbage in its warm-up, a
 * VL53L1X's plausible no-target values after a lock-out restart). Its distance d from the
 * window's estimate (outliving: the end point, the product's value plus the window's lag
 * when it moved; restarted: the product's value, as it lags as the product does) and the
 * noise variance of that comparison. */
static struct kalman_cmp kalman_compare(const struct attitude_state *st,
                                        const struct consensus_axis *product, int32_t kalman_udeg,
                                        int32_t kalman_sigma_udeg, unsigned axis, bool outlives) {
    struct kalman_cmp c = {false, 0, 0};
    if (product == NULL || product->status != CONSENSUS_OK) {
        return c;
    }
    const struct integrity_window *iw = &st->iw;
    int64_t lag = 0;
    int64_t lag_sd = 0;
    if (iw->moved[axis] && outlives) {
        lag = attitude_angle_sd(st, square_mm2(iw->lag_mm[axis]), axis);
        lag = iw->lag_mm[axis] < 0 ? -lag : lag;
        lag_sd = attitude_angle_sd(st, iw->lag_var_mm2[axis], axis);
    }
    const int64_t p2 = (int64_t)product->sigma_udeg * product->sigma_udeg;
    const int64_t k2 = (int64_t)kalman_sigma_udeg * kalman_sigma_udeg;
    c.valid = true;
    c.delta = (int64_t)kalman_udeg - product->angle_udeg - lag;
    c.var = fix_sat_add_s64(fix_sat_add_s64(p2, lag_sd * lag_sd), k2);
    return c;
}

/* sqrt(d² − var): unbiased for the square of the filter's own lag or error beyond the
 * comparison's noise, so no padding when they agree; d beyond motion_sigmas sets *moved
 * (when moved is not NULL). */
static int32_t lag_beyond_noise(const struct attitude_state *st, int64_t delta, int64_t var_s,
                                bool *moved) {
    const uint64_t d = fix_abs_u64(delta);
    if (d > (uint64_t)INT32_MAX) {
        if (moved != NULL) {
            *moved = true;
        }
        return INT32_MAX;
    }
    const uint64_t var = (uint64_t)var_s;
    const uint64_t k = st->cfg.motion_sigmas_q8;
    /* d² > k²·var with k in Q8: compare d·256 against k·sqrt(var) */
    if (moved != NULL && d * 256u > k * fix_isqrt_u64(var)) {
        *moved = true;
    }
    return d * d > var ? (int32_t)fix_isqrt_u64(d * d - var) : 0;
}

/* The lag learnt across blocks: one window's comparison has the window's own
 * noise (3° at N = 10, σ 7 mm), so a filter that outlives its windows and lags a slow
 * motion by less than that (Q = 0, or a Q too small: 1.7° at 0.1°/s) answered `ok` 6 of its
 * sd off. The mean of the comparisons over blocks of N rows (gain 1/b for the first 16
 * blocks, then 1/16: the memory of the drift learning) has 1/31 of one comparison's
 * variance; its excess over that noise is the filter's lag, and beyond motion_sigmas of it
 * the window is `motion`. Once per block; returns the learnt lag (µdeg). */
static int32_t learnt_lag(struct attitude_state *st, const struct kalman_cmp *c, unsigned axis,
                          bool learn, bool *moved) {
    if (learn) {
        const int64_t b = (int64_t)st->kalman_lag_blocks + 1;
        const int64_t m = st->kalman_lag_udeg[axis];
        st->kalman_lag_udeg[axis] = m + fix_div_trunc_s64(c->delta - m, b);
        /* V = ((b − 1)² V + var)/b² (exact 128-bit intermediate, saturating) */
        const int64_t v = st->kalman_lag_var_udeg2[axis];
        st->kalman_lag_var_udeg2[axis] = fix_sat_add_s64(
            fix_muldiv_s64(v, (b - 1) * (b - 1), b * b, NULL), fix_div_trunc_s64(c->var, b * b));
    }
    if (st->kalman_lag_blocks == 0u && !learn) {
        return 0;
    }
    return lag_beyond_noise(st, st->kalman_lag_udeg[axis], st->kalman_lag_var_udeg2[axis], moved);
}

/* The filter's lag on each axis against the window (lag[]: this window's beyond the noise,
 * or the learnt one, whichever is larger) and `motion` when either says so. A filter that
 * outlives its windows is compared with the window's end point and says `motion`; a
 * restarted one (tumbling, Q = 0) that disagrees with its window is wrong, and its sd says
 * by how much. */
static attitude_why_t kalman_lags(struct attitude_state *st,
                                  const struct consensus_product_result *product,
                                  const struct kalman_result *ke, bool restarted, int32_t lag[2]) {
    const bool outlives = st->cfg.mode == ATTITUDE_SLIDING || st->kalman.process_noise;
    bool moved = false;
    bool *ask = outlives ? &moved : NULL;
    const bool learn = outlives && !restarted && st->rows % st->cfg.window == 0u;
    bool learnt_any = false;
    for (unsigned ax = 0; ax < 2u; ++ax) {
        const struct consensus_axis *pa = ax == 0u ? &product->alpha : &product->beta;
        const int32_t k_udeg = ax == 0u ? ke->alpha_udeg : ke->beta_udeg;
        const int32_t k_sigma = ax == 0u ? ke->alpha_sigma_udeg : ke->beta_sigma_udeg;
        const struct kalman_cmp c = kalman_compare(st, pa, k_udeg, k_sigma, ax, outlives);
        if (!c.valid) {
            continue;
        }
        lag[ax] = lag_beyond_noise(st, c.delta, c.var, ask);
        if (outlives && !restarted) {
            const int32_t l = learnt_lag(st, &c, ax, learn, ask);
            lag[ax] = l > lag[ax] ? l : lag[ax];
            learnt_any = learnt_any || learn;
        }
    }
    if (learnt_any && st->kalman_lag_blocks < 16u) {
        st->kalman_lag_blocks++;
    }
    return moved ? ATTITUDE_WHY_MOTION : 0u;
}

void attitude_run_kalman(struct attitude_state *st, const struct consensus_product_result *product,
                         struct attitude_estimate *e) {
    const struct window_stats *w = &st->stats;
    attitude_common_fields(w, e);
    /* the filter's own outcomes for the rows of this window */
    for (unsigned k = 0; k < ATTITUDE_SENSORS; ++k) {
        e->counts[k].used = 0;
        e->counts[k].rejected = 0;
    }
    for (uint16_t age = 0; age < window_fill(&st->window); ++age) {
        const struct window_row *row = window_row_at(&st->window, age);
        for (unsigned k = 0; k < ATTITUDE_SENSORS; ++k) {
            e->counts[k].used = (uint16_t)(e->counts[k].used + ((AUX_USED(row->aux) >> k) & 1u));
            e->counts[k].rejected =
                (uint16_t)(e->counts[k].rejected + ((AUX_REJECTED(row->aux) >> k) & 1u));
        }
    }
    struct kalman_result ke;
    kalman_estimate(&st->kalman, st->cfg.arm_um, &ke);
    e->alpha_udeg = ke.alpha_udeg;
    e->beta_udeg = ke.beta_udeg;
    e->alpha_sigma_udeg = ke.alpha_sigma_udeg;
    e->beta_sigma_udeg = ke.beta_sigma_udeg;
    e->distance_valid = ke.alpha_observable || ke.beta_observable;
    e->distance_um = e->distance_valid ? attitude_q32_mm_to_um(ke.distance_mm) : 0;
    const bool restarted = st->kalman_rows_since_restart < st->cfg.window; /* inside it */
    if (restarted) {
        e->reason = ATTITUDE_REASON_KALMAN_RESTARTED;
    }
    attitude_finish_status(e, ke.alpha_observable, ke.beta_observable);
    int32_t lag[2] = {0, 0};
    attitude_why_t own = 0;
    if (product != NULL) { /* compared with the window's own estimate, every window */
        own = kalman_lags(st, product, &ke, restarted, lag);
    }
    fix_q32_t p00 = ke.p_mm2[0][0] > 0 ? ke.p_mm2[0][0] : attitude_window_white_dist(st);
    int32_t white_a = ke.alpha_sigma_udeg;
    int32_t white_b = ke.beta_sigma_udeg;
    bool guessed = false;
    for (unsigned k = 0; k < ATTITUDE_SENSORS; ++k) {
        guessed = guessed || ((st->iw.used & (1u << k)) != 0u && !st->kalman.r_tracked[k]);
    }
    /* The window's own scatter (the product's predicted σ) bounds the white part from below
     * when the filter's rows are the window's (tumbling with Q = 0, or restarted inside it:
     * its P rests on the tracked R, the window's on what it holds) and, for a filter that
     * outlives its windows, until a window has taught R (P rests on the configured guess: a
     * VL53L1X at 2.5 m read 7.3 mm against the 2 mm guess, and the first window claimed a
     * sd 3.6x too small). `auto` learns R from the readings themselves. */
    const bool window_rows =
        (st->cfg.mode == ATTITUDE_TUMBLING && !st->kalman.process_noise) || restarted;
    if (product != NULL && (window_rows || (guessed && !st->kalman.cfg.process_noise_auto))) {
        if (product->alpha.status == CONSENSUS_OK && product->alpha.sigma_udeg > white_a) {
            white_a = product->alpha.sigma_udeg;
        }
        if (product->beta.status == CONSENSUS_OK && product->beta.sigma_udeg > white_b) {
            white_b = product->beta.sigma_udeg;
        }
        const fix_q32_t d = attitude_window_white_dist(st);
        p00 = d > p00 ? d : p00;
    }
    attitude_settle(st, e, white_a, white_b, p00, lag[0], lag[1], own);
}
