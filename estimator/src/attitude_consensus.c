/* The two consensus estimates of a window: the product rule and the paper's weighting. */
#include <string.h>

#include "attitude_internal.h"

void attitude_run_product(struct attitude_state *st, struct consensus_product_result *res,
                          struct attitude_estimate *e) {
    const struct window_stats *w = &st->stats;
    struct consensus_product_input in;
    (void)memset(&in, 0, sizeof in);
    in.arm_um = st->cfg.arm_um;
    in.tolerance_udeg = st->cfg.consensus_tolerance_udeg;
    for (unsigned k = 0; k < ATTITUDE_SENSORS; ++k) {
        in.sensor[k].used = w->sensor[k].used != 0u;
        in.sensor[k].count = w->sensor[k].used;
        in.sensor[k].mean_mm = w->sensor[k].mean_mm;
        in.sensor[k].var_mm2 = w->sensor[k].var_mm2;
    }
    consensus_product(&in, res);
    attitude_common_fields(w, e);
    e->alpha_udeg = res->alpha.angle_udeg;
    e->beta_udeg = res->beta.angle_udeg;
    e->alpha_sigma_udeg = res->alpha.sigma_udeg;
    e->beta_sigma_udeg = res->beta.sigma_udeg;
    e->alpha_iterations = res->alpha.iterations;
    e->beta_iterations = res->beta.iterations;
    e->distance_valid = res->distance_valid;
    e->distance_um = res->distance_valid ? attitude_q32_mm_to_um(res->distance_mm) : 0;
    if (res->alpha.status == CONSENSUS_NO_CONVERGENCE ||
        res->beta.status == CONSENSUS_NO_CONVERGENCE) {
        e->reason = ATTITUDE_REASON_NO_CONVERGENCE;
    }
    attitude_finish_status(e, res->alpha.status == CONSENSUS_OK, res->beta.status == CONSENSUS_OK);
    attitude_settle(st, e, res->alpha.sigma_udeg, res->beta.sigma_udeg,
                    attitude_window_white_dist(st), 0, 0, 0u);
}

static enum attitude_reason paper_reason(enum consensus_status s) {
    switch (s) {
    case CONSENSUS_TOO_FEW_ROWS:
        return ATTITUDE_REASON_PAPER_TOO_FEW_ROWS;
    case CONSENSUS_NONPOSITIVE_VARIANCE:
        return ATTITUDE_REASON_PAPER_NONPOSITIVE_VARIANCE;
    case CONSENSUS_ZERO_COVARIANCE:
        return ATTITUDE_REASON_PAPER_ZERO_COVARIANCE;
    case CONSENSUS_ZERO_ROW_SUM:
        return ATTITUDE_REASON_PAPER_ZERO_ROW_SUM;
    case CONSENSUS_NEGATIVE_ROW_SUM:
        return ATTITUDE_REASON_PAPER_NEGATIVE_ROW_SUM;
    case CONSENSUS_OVERFLOW:
        return ATTITUDE_REASON_PAPER_OVERFLOW;
    case CONSENSUS_DIVERGED:
        return ATTITUDE_REASON_PAPER_DIVERGED;
    case CONSENSUS_NO_CONVERGENCE:
        return ATTITUDE_REASON_PAPER_NO_CONVERGENCE;
    case CONSENSUS_OUTSIDE_HULL:
        return ATTITUDE_REASON_PAPER_OUTSIDE_HULL;
    default:
        return ATTITUDE_REASON_NONE;
    }
}

/* True when the paper's value lies within k·σ + tol of the product's. */
static bool paper_consistent(const struct attitude_config *cfg, int32_t paper_udeg,
                             const struct consensus_axis *product) {
    if (cfg->paper_consistency_sigmas_q8 == 0u || product->status != CONSENSUS_OK) {
        return true;
    }
    const int64_t diff = (int64_t)paper_udeg - product->angle_udeg;
    const int64_t limit = (((int64_t)cfg->paper_consistency_sigmas_q8 * product->sigma_udeg) >> 8) +
                          cfg->consensus_tolerance_udeg;
    return (diff < 0 ? -diff : diff) <= limit;
}

void attitude_run_paper(struct attitude_state *st, const struct consensus_product_result *product,
                        struct attitude_estimate *e) {
    const struct window_stats *w = &st->stats;
    attitude_common_fields(w, e);
    const struct consensus_paper_config pcfg = {.tolerance_udeg = st->cfg.consensus_tolerance_udeg,
                                                .max_iterations = st->cfg.paper_max_iterations};
    struct consensus_paper_result ra;
    struct consensus_paper_result rb;
    consensus_paper(w->alpha.complete_mean, w->alpha.cov, w->complete, &pcfg, &ra);
    consensus_paper(w->beta.complete_mean, w->beta.cov, w->complete, &pcfg, &rb);
    e->alpha_iterations = ra.iterations;
    e->beta_iterations = rb.iterations;
    e->alpha_udeg = ra.angle_udeg;
    e->beta_udeg = rb.angle_udeg;
    e->distance_valid = attitude_pair_midpoints_um(w, &e->distance_um);
    bool alpha_ok = ra.status == CONSENSUS_OK;
    bool beta_ok = rb.status == CONSENSUS_OK;
    if (!alpha_ok) {
        e->reason = paper_reason(ra.status);
    } else if (!beta_ok) {
        e->reason = paper_reason(rb.status);
    } else {
        /* both converged: the consistency checks below decide */
    }
    /* A faithful P can converge to a poor value without any numerical sign:
     * check it against the product estimate of the same window. */
    if (alpha_ok && !paper_consistent(&st->cfg, ra.angle_udeg, &product->alpha)) {
        alpha_ok = false;
        e->reason = ATTITUDE_REASON_PAPER_INCONSISTENT;
    }
    if (beta_ok && !paper_consistent(&st->cfg, rb.angle_udeg, &product->beta)) {
        beta_ok = false;
        if (e->reason == ATTITUDE_REASON_NONE) {
            e->reason = ATTITUDE_REASON_PAPER_INCONSISTENT;
        }
    }
    attitude_finish_status(e, alpha_ok, beta_ok);
    /* A converged paper value is Σ d_i v_i / Σ d_i with every d_i > 0 (consensus.h): a
     * convex combination, whose variance cannot exceed the largest of its terms' */
    const fix_q32_t *v = st->iw.white_mm2;
    const fix_q32_t pairs[6] = {v[0] + v[1],
                                v[0] + v[3],
                                v[1] + v[2],
                                v[2] + v[3],
                                fix_asr_s64(v[0] + v[2], 2u),
                                fix_asr_s64(v[1] + v[3], 2u)};
    fix_q32_t worst = 0;
    for (unsigned i = 0; i < 6u; ++i) {
        worst = pairs[i] > worst ? pairs[i] : worst;
    }
    attitude_settle(st, e, attitude_angle_sd(st, worst, 0u), attitude_angle_sd(st, worst, 1u),
                    attitude_window_white_dist(st), 0, 0, 0u);
}
