/* host_sim replay's statistics against the trace's truth (replay_stats.h). */
#include "replay_stats.h"

#include <string.h>

#include "scene/crb.h"

static void err_add(double err, uint64_t *n, double *sum2, double *sum_abs, double *max) {
    ++*n;
    *sum2 += err * err;
    *sum_abs += fabs(err);
    if (fabs(err) > *max) {
        *max = fabs(err);
    }
}

double replay_rms(double sum2, uint64_t n) {
    return n > 0u ? sqrt(sum2 / (double)n) : NO_VALUE;
}

static void calib_add(struct calib_axis *c, double err, double sd) {
    ++c->n;
    c->within3 += fabs(err) <= 3.0 * sd;
    c->beyond6 += fabs(err) > 6.0 * sd;
    c->sum2_err += err * err;
    c->sum2_sd += sd * sd;
}

double replay_share(uint64_t k, uint64_t n) {
    return n > 0u ? (double)k / (double)n : NO_VALUE;
}

double replay_calib_ratio(const struct calib_axis *c) {
    return c->n > 0u && c->sum2_sd > 0.0 ? sqrt(c->sum2_err / c->sum2_sd) : NO_VALUE;
}

double replay_answered(const struct err_stats *s) {
    const uint64_t total = (uint64_t)s->status_count[0] + s->status_count[1] + s->status_count[2];
    return replay_share(s->status_count[0] + s->status_count[1], total);
}

static void window_truth_add(struct replay_stats *s, const struct scene_row *row) {
    for (unsigned k = 0; k < 4; ++k) {
        if (scene_row_valid(row, k)) {
            ++s->win.n[k];
            s->win.sum[k] += row->range_mm[k];
            s->win.sum2[k] += (double)row->range_mm[k] * row->range_mm[k];
        }
    }
}

/* The bound of the window just finished: per-sensor σ from the window's own readings
 * (the plate is static within a window in the protocols this serves), floored at the
 * 1 mm quantisation noise, 1/12 mm². */
static void window_truth_close(struct replay_stats *s, const struct scene_row *last,
                               double arm_mm) {
    double sigma[4];
    for (unsigned k = 0; k < 4; ++k) {
        const double n = s->win.n[k];
        double var = 0.0;
        if (n >= 2.0) {
            var = (s->win.sum2[k] - s->win.sum[k] * s->win.sum[k] / n) / (n - 1.0);
        }
        sigma[k] = sqrt(var > 1.0 / 12.0 ? var : 1.0 / 12.0);
    }
    struct scene_crb crb;
    s->last_crb_alpha = NO_VALUE;
    s->last_crb_beta = NO_VALUE;
    if (last->has_alpha && last->has_beta &&
        scene_crb(arm_mm, sigma, s->win.n, last->alpha_deg, last->beta_deg, &crb) == 0) {
        s->crb_sum2_alpha += crb.sd_alpha_deg * crb.sd_alpha_deg;
        s->crb_sum2_beta += crb.sd_beta_deg * crb.sd_beta_deg;
        ++s->crb_windows;
        s->last_crb_alpha = crb.sd_alpha_deg;
        s->last_crb_beta = crb.sd_beta_deg;
    }
    memset(&s->win, 0, sizeof s->win);
}

void replay_stats_sample(struct replay_stats *s, const struct scene_row *row, bool window_end,
                         double arm_mm) {
    s->truth_seen = s->truth_seen || row->has_alpha || row->has_beta;
    window_truth_add(s, row);
    if (window_end) {
        window_truth_close(s, row, arm_mm);
    }
}

/* An ok estimate more than 5x its window's bound from the truth went unflagged. */
static bool unflagged_wrong(const struct replay_stats *s, const struct scene_row *row,
                            const struct attitude_estimate *est) {
    return est->status == ATTITUDE_OK &&
           ((row->has_alpha && est->alpha_valid &&
             fabs(est->alpha_udeg / 1e6 - row->alpha_deg) > 5.0 * s->last_crb_alpha) ||
            (row->has_beta && est->beta_valid &&
             fabs(est->beta_udeg / 1e6 - row->beta_deg) > 5.0 * s->last_crb_beta));
}

/* One estimator's estimate: its status, reasons, errors and sd calibration. */
static void estimate_add(struct replay_stats *s, unsigned e, const struct scene_row *row,
                         const struct attitude_estimate *est, bool sliding) {
    struct err_stats *st = &s->est[e];
    ++st->status_count[est->status <= ATTITUDE_INVALID ? est->status : ATTITUDE_INVALID];
    if (!sliding && unflagged_wrong(s, row, est)) {
        ++s->unflagged_wrong[e];
    }
    for (unsigned b = 0; b < WHY_BITS; ++b) {
        s->why_count[e][b] += (uint32_t)((est->why >> b) & 1u);
    }
    if (est->status != ATTITUDE_INVALID && row->has_alpha && est->alpha_valid) {
        calib_add(&s->calib[e][0], est->alpha_udeg / 1e6 - row->alpha_deg,
                  est->alpha_sd_udeg / 1e6);
    }
    if (est->status != ATTITUDE_INVALID && row->has_beta && est->beta_valid) {
        calib_add(&s->calib[e][1], est->beta_udeg / 1e6 - row->beta_deg, est->beta_sd_udeg / 1e6);
    }
    if (row->has_alpha && est->alpha_valid) {
        err_add(est->alpha_udeg / 1e6 - row->alpha_deg, &st->n_alpha, &st->sum2_alpha,
                &st->sum_abs_alpha, &st->max_alpha);
    }
    if (row->has_beta && est->beta_valid) {
        err_add(est->beta_udeg / 1e6 - row->beta_deg, &st->n_beta, &st->sum2_beta,
                &st->sum_abs_beta, &st->max_beta);
    }
}

void replay_stats_estimate(struct replay_stats *s, const struct scene_row *row,
                           const struct attitude_output *out, bool sliding) {
    ++s->estimates;
    for (unsigned e = 0; e < ATTITUDE_EST_COUNT; ++e) {
        if (out->est[e].reason != ATTITUDE_REASON_DISABLED) {
            estimate_add(s, e, row, &out->est[e], sliding);
        }
    }
}
