/* The shared finishing of an estimate: status from observability, the why set and the sd. */
#include <string.h>

#include "attitude_internal.h"

void attitude_common_fields(const struct window_stats *w, struct attitude_estimate *e) {
    (void)memset(e, 0, sizeof *e);
    e->flatness_valid = w->residual_valid;
    e->flatness_residual_um = w->residual_um;
    for (unsigned k = 0; k < ATTITUDE_SENSORS; ++k) {
        e->counts[k].used = w->sensor[k].used;
        e->counts[k].flagged = w->sensor[k].flagged;
        e->counts[k].missing = w->sensor[k].missing;
        e->counts[k].rejected = w->sensor[k].rejected;
    }
}

/* Sets validity, status and reason from observability; attitude_settle() adds the integrity. */
void attitude_finish_status(struct attitude_estimate *e, bool alpha_ok, bool beta_ok) {
    e->alpha_valid = alpha_ok;
    e->beta_valid = beta_ok;
    if (!alpha_ok) {
        e->alpha_udeg = 0;
        e->alpha_sigma_udeg = 0;
    }
    if (!beta_ok) {
        e->beta_udeg = 0;
        e->beta_sigma_udeg = 0;
    }
    if (!alpha_ok || !beta_ok) {
        e->status = ATTITUDE_INVALID;
        /* "kalman-restarted" is a degraded reason: an invalid estimate names its axes */
        if (e->reason == ATTITUDE_REASON_NONE || e->reason == ATTITUDE_REASON_KALMAN_RESTARTED) {
            if (alpha_ok) {
                e->reason = ATTITUDE_REASON_BETA_UNOBSERVABLE;
            } else if (beta_ok) {
                e->reason = ATTITUDE_REASON_ALPHA_UNOBSERVABLE;
            } else {
                e->reason = ATTITUDE_REASON_UNOBSERVABLE;
            }
        }
        return;
    }
    bool missing_sensor = false;
    bool flagged = false;
    for (unsigned k = 0; k < ATTITUDE_SENSORS; ++k) {
        const struct attitude_sensor_counts *c = &e->counts[k];
        missing_sensor = missing_sensor || c->used == 0u;
        flagged = flagged || c->flagged != 0u || c->missing != 0u || c->rejected != 0u;
    }
    if (missing_sensor) {
        e->status = ATTITUDE_DEGRADED;
        e->reason = ATTITUDE_REASON_SENSOR_MISSING;
    } else if (e->reason == ATTITUDE_REASON_KALMAN_RESTARTED || flagged) {
        e->status = ATTITUDE_DEGRADED;
        if (e->reason == ATTITUDE_REASON_NONE) {
            e->reason = ATTITUDE_REASON_FLAGGED_DATA;
        }
    } else {
        e->status = ATTITUDE_OK;
        e->reason = ATTITUDE_REASON_NONE;
    }
}

/* sqrt(a² + b² + c²) of three 1σ in µdeg, saturating, at least 1 (a claimed sd is never
 * 0): one square root for the three parts of an angle's sd. */
static int32_t hypot3_udeg(int32_t a, int32_t b, int32_t c) {
    const int64_t a2s = (int64_t)a * a;
    const int64_t b2s = (int64_t)b * b;
    const int64_t c2s = (int64_t)c * c;
    const uint64_t a2 = (uint64_t)a2s;
    const uint64_t b2 = (uint64_t)b2s;
    const uint64_t c2 = (uint64_t)c2s;
    uint64_t sum = a2 > UINT64_MAX - b2 ? UINT64_MAX : a2 + b2;
    sum = sum > UINT64_MAX - c2 ? UINT64_MAX : sum + c2;
    const uint32_t root = fix_isqrt_u64(sum);
    return root == 0u ? 1 : (root > (uint32_t)INT32_MAX ? INT32_MAX : (int32_t)root);
}

/* An angle's 1σ from its y = a·tan variance (Q32 mm²) at the window's slope. */
int32_t attitude_angle_sd(const struct attitude_state *st, fix_q32_t var_mm2, unsigned axis) {
    return fix_angle_sigma_udeg(var_mm2, st->cfg.arm_um, st->iw.tan_q32[axis]);
}

int32_t attitude_extra_sd(const struct attitude_state *st, fix_q32_t var_mm2, unsigned axis) {
    fix_q32_t t = st->iw.tan_q32[axis];
    if (st->cal_spread) {
        /* the slope 3 sd of y nearer 0 (where atan is steepest): a calibration error of
         * tens of mm moves the estimate by tens of degrees, and the slope at the estimate
         * would under-state how far the truth may be (docs/explanation/estimators.md
         * "Calibration"); sqrt(Q32 mm²) is Q16 mm, as a Q32 slope · 2^16 / a mm, with the
         * window's reciprocal of a (2^(31 + shift) / a mm) */
        const struct angles_arm *arm = &st->window.arm;
        const int64_t s3 = fix_mul_shr_s64((int64_t)fix_isqrt_u64((uint64_t)var_mm2) * 3,
                                           (int64_t)arm->inv, 15u + arm->shift, NULL);
        const fix_q32_t mag = t < 0 ? -t : t;
        const fix_q32_t near = mag > s3 ? mag - s3 : 0;
        t = t < 0 ? -near : near;
    }
    return fix_angle_sigma_udeg(var_mm2, st->cfg.arm_um, t);
}

/*
 * The integrity of one estimate (docs/explanation/estimators.md "Integrity"): the why set from
 * the window's facts and the estimator's own counts and reason, the sd from the
 * estimator's white-noise 1σ (white_*) and what the window adds (drift, prior, rounding,
 * a failed parity, motion), and the status: ok only with both angles and an empty set.
 */
void attitude_settle(const struct attitude_state *st, struct attitude_estimate *e,
                     int32_t white_alpha_udeg, int32_t white_beta_udeg, fix_q32_t white_dist_mm2,
                     int32_t extra_alpha_udeg, int32_t extra_beta_udeg, attitude_why_t own) {
    const struct integrity_window *iw = &st->iw;
    attitude_why_t why = iw->why | own;
    for (unsigned k = 0; k < ATTITUDE_SENSORS; ++k) {
        if (e->counts[k].rejected != 0u) {
            why |= ATTITUDE_WHY_REJECTED(k);
        }
    }
    if (e->reason != ATTITUDE_REASON_NONE && e->reason != ATTITUDE_REASON_FLAGGED_DATA &&
        e->reason != ATTITUDE_REASON_SENSOR_MISSING) {
        why |= ATTITUDE_WHY_REASON(e->reason);
    }
    e->alpha_sd_udeg = 0;
    e->beta_sd_udeg = 0;
    e->distance_sd_um = 0;
    if (e->alpha_valid) {
        e->alpha_sd_udeg = hypot3_udeg(white_alpha_udeg, st->extra_udeg[0], extra_alpha_udeg);
    }
    if (e->beta_valid) {
        e->beta_sd_udeg = hypot3_udeg(white_beta_udeg, st->extra_udeg[1], extra_beta_udeg);
    }
    if (e->distance_valid) {
        const fix_q32_t var =
            fix_sat_add_s64(white_dist_mm2, iw->extra_var_mm2[INTEGRITY_DISTANCE]);
        /* sqrt of Q32 mm² is Q16 mm: µm = root · 1000 / 2^16, rounded, at least 1 */
        const uint64_t um = ((uint64_t)fix_isqrt_u64((uint64_t)var) * 1000u + 32768u) >> 16;
        e->distance_sd_um = um == 0u ? 1 : (um > (uint64_t)INT32_MAX ? INT32_MAX : (int32_t)um);
    }
    if (e->status == ATTITUDE_OK && why != 0u) { /* never upgraded, only downgraded */
        e->status = ATTITUDE_DEGRADED;
        e->reason = ATTITUDE_REASON_FLAGGED_DATA;
    }
    if (e->status != ATTITUDE_OK && why == 0u) { /* a not-ok estimate always says why */
        why = ATTITUDE_WHY_REASON(e->reason);
    }
    e->why = e->status == ATTITUDE_OK ? 0u : why;
}

fix_q32_t attitude_window_white_dist(const struct attitude_state *st) {
    fix_q32_t var = 0;
    (void)integrity_axis_var(INTEGRITY_DISTANCE, st->iw.used, st->iw.white_mm2, &var);
    return var;
}

/* Mean distance: the midpoint of each complete opposite pair, averaged. */
bool attitude_pair_midpoints_um(const struct window_stats *w, int32_t *out_um) {
    const bool ac = w->sensor[ANGLES_A].used != 0u && w->sensor[ANGLES_C].used != 0u;
    const bool bd = w->sensor[ANGLES_B].used != 0u && w->sensor[ANGLES_D].used != 0u;
    int64_t sum = 0;
    int64_t n = 0;
    if (ac) {
        sum += w->sensor[ANGLES_A].mean_mm + w->sensor[ANGLES_C].mean_mm;
        n += 2;
    }
    if (bd) {
        sum += w->sensor[ANGLES_B].mean_mm + w->sensor[ANGLES_D].mean_mm;
        n += 2;
    }
    if (n == 0) {
        *out_um = 0;
        return false;
    }
    *out_um = fix_sat_s32(fix_muldiv_s64(sum, 1000, n * FIX_Q32_ONE, NULL));
    return true;
}

int32_t attitude_q32_mm_to_um(fix_q32_t mm) {
    return fix_sat_s32(fix_mul_shr_s64(mm, 1000, FIX_Q32_SHIFT, NULL));
}

void attitude_disabled(struct attitude_estimate *e, const struct window_stats *w) {
    attitude_common_fields(w, e);
    e->reason = ATTITUDE_REASON_DISABLED;
    attitude_finish_status(e, false, false);
    e->reason = ATTITUDE_REASON_DISABLED;
    e->why = ATTITUDE_WHY_REASON(ATTITUDE_REASON_DISABLED);
}
