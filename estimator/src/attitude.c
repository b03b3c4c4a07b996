/* The estimator facade: see estimator/attitude.h. */
#include "estimator/attitude.h"

#include <string.h>

#include "fix_inline.h"

_Static_assert((ATTITUDE_EST_BUILT) != 0u && ((ATTITUDE_EST_BUILT) & ~0x0Fu) == 0u,
               "ATTITUDE_EST_BUILT: a non-empty mask of the four estimators");

/* Kalman outcomes kept per row in window_row.aux: low nibble used, high rejected. */
#define AUX_USED(m)     ((uint8_t)((m)&0x0Fu))
#define AUX_REJECTED(m) ((uint8_t)(((m) >> 4) & 0x0Fu))
#define AUX_MAKE(u, r)  ((uint8_t)(((u)&0x0Fu) | (((r)&0x0Fu) << 4)))

static const uint8_t bit_a = ANGLES_BIT(ANGLES_A);
static const uint8_t bit_b = ANGLES_BIT(ANGLES_B);
static const uint8_t bit_c = ANGLES_BIT(ANGLES_C);
static const uint8_t bit_d = ANGLES_BIT(ANGLES_D);

void attitude_config_default(struct attitude_config *cfg) {
    const struct attitude_config defaults = ATTITUDE_CONFIG_DEFAULT;
    *cfg = defaults;
}

const char *attitude_error_message(int err) {
    switch (err) {
    case ATTITUDE_ERR_NONE:
        return "";
    case ATTITUDE_ERR_ARM:
        return "arm_um outside [1000, 1000000] um";
    case ATTITUDE_ERR_WINDOW:
        return "window outside [2, ATTITUDE_WINDOW_MAX] rows";
    case ATTITUDE_ERR_MODE:
        return "mode is neither tumbling nor sliding";
    case ATTITUDE_ERR_ESTIMATORS:
        return "estimators selects none, or one unknown or not built into this image";
    case ATTITUDE_ERR_TOLERANCE:
        return "consensus_tolerance_udeg outside [1, 10000000]";
    case ATTITUDE_ERR_PAPER_ITERATIONS:
        return "paper_max_iterations is 0";
    case ATTITUDE_ERR_KALMAN_PROCESS_NOISE:
        return "kalman_process_noise_um2 too large";
    case ATTITUDE_ERR_KALMAN_MEASUREMENT_NOISE:
        return "kalman_initial_noise_um2 below 83334 (1/12 mm², the 1 mm rounding)";
    case ATTITUDE_ERR_KALMAN_WARMUP:
        return "kalman_warmup_rows outside [1, 8]";
    case ATTITUDE_ERR_KALMAN_NOISE_SHIFT:
        return "kalman_noise_shift above 8";
    case ATTITUDE_ERR_NULL:
        return "NULL state or config";
    case ATTITUDE_ERR_INTEGRITY:
        return "an integrity field out of range (range_max_mm 1..8189, parity/motion sigmas "
               "1..16 x 256, drift_shift 1..8)";
    case ATTITUDE_ERR_BUFFER:
        return "buffer too small";
    default:
        return "unknown attitude error";
    }
}

/* um² (uint32) as Q32 mm²: x · 2^32 / 1e6, rounded. */
static fix_q32_t um2_to_q32_mm2(uint32_t um2) {
    return fix_muldiv_s64((int64_t)um2, FIX_Q32_ONE, 1000000, NULL);
}

int attitude_init(struct attitude_state *st, const struct attitude_config *cfg) {
    if (st == NULL || cfg == NULL) {
        return ATTITUDE_ERR_NULL;
    }
    if (!angles_arm_valid(cfg->arm_um)) {
        return ATTITUDE_ERR_ARM;
    }
    if (cfg->window < WINDOW_MIN_SAMPLES || cfg->window > ATTITUDE_WINDOW_MAX) {
        return ATTITUDE_ERR_WINDOW;
    }
    if (cfg->mode != ATTITUDE_TUMBLING && cfg->mode != ATTITUDE_SLIDING) {
        return ATTITUDE_ERR_MODE;
    }
    if (cfg->estimators == 0u || (cfg->estimators | ATTITUDE_EST_BUILT) != ATTITUDE_EST_BUILT) {
        return ATTITUDE_ERR_ESTIMATORS;
    }
    if (cfg->consensus_tolerance_udeg < 1 || cfg->consensus_tolerance_udeg > 10000000) {
        return ATTITUDE_ERR_TOLERANCE;
    }
    if (cfg->paper_max_iterations == 0u) {
        return ATTITUDE_ERR_PAPER_ITERATIONS;
    }
    const struct integrity_config icfg = {.arm_um = cfg->arm_um,
                                          .range_max_mm = cfg->range_max_mm,
                                          .parity_sigmas_q8 = cfg->parity_sigmas_q8,
                                          .motion_sigmas_q8 = cfg->motion_sigmas_q8,
                                          .offset_stability_um = cfg->offset_stability_um,
                                          .drift_flag_um = cfg->drift_flag_um,
                                          .drift_shift = cfg->drift_shift};
    if (!integrity_config_valid(&icfg)) {
        return ATTITUDE_ERR_INTEGRITY;
    }
    struct kalman_config kcfg;
    (void)memset(&kcfg, 0, sizeof kcfg);
    for (unsigned i = 0; i < KALMAN_STATES; ++i) {
        kcfg.process_noise_mm2[i] = um2_to_q32_mm2(cfg->kalman_process_noise_um2[i]);
    }
    for (unsigned s = 0; s < ATTITUDE_SENSORS; ++s) {
        kcfg.initial_noise_mm2[s] = um2_to_q32_mm2(cfg->kalman_initial_noise_um2[s]);
    }
    kcfg.gate_sigmas_q8 = cfg->kalman_gate_sigmas_q8;
    kcfg.gate_floor_mm = cfg->gate_floor_mm;
    kcfg.warmup_rows = cfg->kalman_warmup_rows;
    kcfg.noise_shift = cfg->kalman_noise_shift;
    kcfg.process_noise_auto = cfg->kalman_process_noise_auto;
    /* every check before the state is touched: a refusal changes nothing (a run-time
     * command re-initialising with a new setting keeps the old one) */
    switch (kalman_config_check(&kcfg)) {
    case KALMAN_OK:
        break;
    case KALMAN_ERR_PROCESS_NOISE:
        return ATTITUDE_ERR_KALMAN_PROCESS_NOISE;
    case KALMAN_ERR_MEASUREMENT_NOISE:
        return ATTITUDE_ERR_KALMAN_MEASUREMENT_NOISE;
    case KALMAN_ERR_WARMUP:
        return ATTITUDE_ERR_KALMAN_WARMUP;
    default:
        return ATTITUDE_ERR_KALMAN_NOISE_SHIFT;
    }
    (void)memset(st, 0, sizeof *st);
    st->cfg = *cfg;
    st->icfg = icfg;
    integrity_init(&st->integrity);
    st->kalman_rows_since_restart = UINT32_MAX;
    const struct window_config wcfg = {.arm_um = cfg->arm_um,
                                       .length = cfg->window,
                                       .gate_sigmas_q8 = cfg->gate_sigmas_q8,
                                       .gate_floor_mm = cfg->gate_floor_mm};
    if (window_init(&st->window, &wcfg) != WINDOW_OK) {
        return ATTITUDE_ERR_WINDOW; /* unreachable: checked above */
    }
    (void)kalman_init(&st->kalman, &kcfg); /* checked above */
    return ATTITUDE_ERR_NONE;
}

/* --- status helpers ------------------------------------------------------------------ */

/* α needs A and C, or B and D plus one of A, C (DESIGN.md §2 model, rank of H). */
static bool alpha_observable(uint8_t s) {
    const bool ac = (s & (bit_a | bit_c)) == (bit_a | bit_c);
    const bool bd = (s & (bit_b | bit_d)) == (bit_b | bit_d);
    return ac || (bd && (s & (bit_a | bit_c)) != 0u);
}
static bool beta_observable(uint8_t s) {
    const bool ac = (s & (bit_a | bit_c)) == (bit_a | bit_c);
    const bool bd = (s & (bit_b | bit_d)) == (bit_b | bit_d);
    return bd || (ac && (s & (bit_b | bit_d)) != 0u);
}

/* Sets validity, status and reason from observability; settle() adds the integrity. */
static void finish_status(struct attitude_estimate *e, bool alpha_ok, bool beta_ok) {
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
static int32_t angle_sd(const struct attitude_state *st, fix_q32_t var_mm2, unsigned axis) {
    return fix_angle_sigma_udeg(var_mm2, st->cfg.arm_um, st->iw.tan_q32[axis]);
}

/*
 * The integrity of one estimate (docs/estimator-design.md "Integrity"): the why set from
 * the window's facts and the estimator's own counts and reason, the sd from the
 * estimator's white-noise 1σ (white_*) and what the window adds (drift, prior, rounding,
 * a failed parity, motion), and the status: ok only with both angles and an empty set.
 */
static void settle(const struct attitude_state *st, struct attitude_estimate *e,
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

/* v² in Q32 mm² for v in Q32 mm, saturating. */
static fix_q32_t square_mm2(fix_q32_t v) {
    return fix_s128_to_s64(fix_s128_shr_round(fix_s128_mul(v, v), FIX_Q32_SHIFT), NULL);
}

static fix_q32_t window_white_dist(const struct attitude_state *st) {
    fix_q32_t var = 0;
    (void)integrity_axis_var(INTEGRITY_DISTANCE, st->iw.used, st->iw.white_mm2, &var);
    return var;
}

/* Mean distance: the midpoint of each complete opposite pair, averaged. */
static bool pair_midpoints_um(const struct window_stats *w, int32_t *out_um) {
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

static int32_t q32_mm_to_um(fix_q32_t mm) {
    return fix_sat_s32(fix_mul_shr_s64(mm, 1000, FIX_Q32_SHIFT, NULL));
}

static void common_fields(const struct window_stats *w, struct attitude_estimate *e) {
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

static uint8_t sensors_used(const struct attitude_estimate *e) {
    uint8_t m = 0;
    for (unsigned k = 0; k < ATTITUDE_SENSORS; ++k) {
        if (e->counts[k].used != 0u) {
            m = (uint8_t)(m | (1u << k));
        }
    }
    return m;
}

/* --- the four estimators ----------------------------------------------------------------- */

FIX_NOINLINE void run_product(struct attitude_state *st, struct consensus_product_result *res,
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
    common_fields(w, e);
    e->alpha_udeg = res->alpha.angle_udeg;
    e->beta_udeg = res->beta.angle_udeg;
    e->alpha_sigma_udeg = res->alpha.sigma_udeg;
    e->beta_sigma_udeg = res->beta.sigma_udeg;
    e->alpha_iterations = res->alpha.iterations;
    e->beta_iterations = res->beta.iterations;
    e->distance_valid = res->distance_valid;
    e->distance_um = res->distance_valid ? q32_mm_to_um(res->distance_mm) : 0;
    if (res->alpha.status == CONSENSUS_NO_CONVERGENCE ||
        res->beta.status == CONSENSUS_NO_CONVERGENCE) {
        e->reason = ATTITUDE_REASON_NO_CONVERGENCE;
    }
    finish_status(e, res->alpha.status == CONSENSUS_OK, res->beta.status == CONSENSUS_OK);
    settle(st, e, res->alpha.sigma_udeg, res->beta.sigma_udeg, window_white_dist(st), 0, 0, 0u);
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

FIX_NOINLINE void run_paper(struct attitude_state *st,
                            const struct consensus_product_result *product,
                            struct attitude_estimate *e) {
    const struct window_stats *w = &st->stats;
    common_fields(w, e);
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
    e->distance_valid = pair_midpoints_um(w, &e->distance_um);
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
    finish_status(e, alpha_ok, beta_ok);
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
    settle(st, e, angle_sd(st, worst, 0u), angle_sd(st, worst, 1u), window_white_dist(st), 0, 0,
           0u);
}

/* White variance (Q32 mm² of y = a·tan) of the plain mean of the estimates available on
 * one axis: Σ_k c_k² V_k with c the average of their sensor coefficients (units 1/2). */
static fix_q32_t mean_white_var(const struct attitude_state *st, const struct window_axis_stats *ax,
                                bool beta) {
    /* α1 = (B − A)/a, α2 = (D − A)/a, α3 = (C − B)/a, α4 = (C − D)/a, α5 = (C − A)/2a;
     * β1 = (A − D)/a, β2 = (C − D)/a, β3 = (B − A)/a, β4 = (B − C)/a, β5 = (B − D)/2a */
    static const int8_t coef[2][ANGLES_PER_AXIS][ATTITUDE_SENSORS] = {
        {{-2, 2, 0, 0}, {-2, 0, 0, 2}, {0, -2, 2, 0}, {0, 0, 2, -2}, {-1, 0, 1, 0}},
        {{2, 0, 0, -2}, {0, 0, 2, -2}, {-2, 2, 0, 0}, {0, 2, -2, 0}, {0, 1, 0, -1}},
    };
    int32_t c[ATTITUDE_SENSORS] = {0, 0, 0, 0};
    int32_t n = 0;
    for (unsigned i = 0; i < ANGLES_PER_AXIS; ++i) {
        if (ax->count[i] != 0u) {
            n++;
            for (unsigned k = 0; k < ATTITUDE_SENSORS; ++k) {
                c[k] += coef[beta ? 1 : 0][i][k];
            }
        }
    }
    if (n == 0) {
        return 0;
    }
    fix_q32_t sum = 0;
    for (unsigned k = 0; k < ATTITUDE_SENSORS; ++k) {
        sum = fix_sat_add_s64(sum, fix_sat_mul_s64(st->iw.white_mm2[k], (int64_t)c[k] * c[k]));
    }
    return fix_div_round_s64(sum, 4 * (int64_t)n * n);
}

static int32_t mean_of_angles(const struct window_axis_stats *ax) {
    int64_t sum = 0;
    int64_t n = 0;
    for (unsigned i = 0; i < ANGLES_PER_AXIS; ++i) {
        if (ax->count[i] != 0u) {
            sum += ax->mean[i];
            n++;
        }
    }
    return n == 0 ? 0 : fix_sat_s32(fix_div_round_s64(sum, n << FIX_UDEG_Q_SHIFT));
}

static void run_mean(struct attitude_state *st, struct attitude_estimate *e) {
    const struct window_stats *w = &st->stats;
    common_fields(w, e);
    const uint8_t s = sensors_used(e);
    e->alpha_udeg = mean_of_angles(&w->alpha);
    e->beta_udeg = mean_of_angles(&w->beta);
    e->distance_valid = pair_midpoints_um(w, &e->distance_um);
    finish_status(e, alpha_observable(s), beta_observable(s));
    settle(st, e, angle_sd(st, mean_white_var(st, &w->alpha, false), 0u),
           angle_sd(st, mean_white_var(st, &w->beta, true), 1u), window_white_dist(st), 0, 0, 0u);
}

/* A filter that is never reset (sliding mode) can lag a moving plate by more than its
 * window; a tumbling one answers from rows the window's gate may have dropped (garbage in
 * its warm-up, a VL53L1X's plausible no-target values after a lock-out restart). Its
 * distance d from the window's estimate (sliding: the end point, the product's value plus
 * the window's lag when it moved; tumbling: the product's value) beyond the noise of that
 * comparison, sqrt(d² − var), is this estimate's own lag or error (unbiased for its
 * square, so no padding when they agree); d beyond motion_sigmas sets *moved (when
 * moved is not NULL). */
static int32_t kalman_lag_udeg(const struct attitude_state *st,
                               const struct consensus_axis *product, int32_t kalman_udeg,
                               int32_t kalman_sigma_udeg, unsigned axis, bool *moved) {
    if (product == NULL || product->status != CONSENSUS_OK) {
        return 0;
    }
    const struct integrity_window *iw = &st->iw;
    int64_t lag = 0;
    int64_t lag_sd = 0;
    /* a tumbling filter is a window estimator: it lags as the product does, so it is
     * compared with the product itself, not with the window's end point */
    if (iw->moved[axis] && st->cfg.mode == ATTITUDE_SLIDING) {
        lag = angle_sd(st, square_mm2(iw->lag_mm[axis]), axis);
        lag = iw->lag_mm[axis] < 0 ? -lag : lag;
        lag_sd = angle_sd(st, iw->lag_var_mm2[axis], axis);
    }
    const int64_t delta = (int64_t)kalman_udeg - product->angle_udeg - lag;
    const uint64_t d = fix_abs_u64(delta);
    if (d > (uint64_t)INT32_MAX) {
        if (moved != NULL) {
            *moved = true;
        }
        return INT32_MAX;
    }
    const int64_t p2 = (int64_t)product->sigma_udeg * product->sigma_udeg;
    const int64_t k2 = (int64_t)kalman_sigma_udeg * kalman_sigma_udeg;
    const int64_t var_s = fix_sat_add_s64(fix_sat_add_s64(p2, lag_sd * lag_sd), k2);
    const uint64_t var = (uint64_t)var_s;
    const uint64_t k = st->cfg.motion_sigmas_q8;
    /* d² > k²·var with k in Q8: compare d·256 against k·sqrt(var) (moved NULL: not asked) */
    if (moved != NULL && d * 256u > k * fix_isqrt_u64(var)) {
        *moved = true;
    }
    return d * d > var ? (int32_t)fix_isqrt_u64(d * d - var) : 0;
}

FIX_NOINLINE void run_kalman(struct attitude_state *st,
                             const struct consensus_product_result *product,
                             struct attitude_estimate *e) {
    const struct window_stats *w = &st->stats;
    common_fields(w, e);
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
    e->distance_um = e->distance_valid ? q32_mm_to_um(ke.distance_mm) : 0;
    const bool restarted = st->kalman_rows_since_restart < st->cfg.window; /* inside it */
    if (restarted) {
        e->reason = ATTITUDE_REASON_KALMAN_RESTARTED;
    }
    finish_status(e, ke.alpha_observable, ke.beta_observable);
    int32_t lag_a = 0;
    int32_t lag_b = 0;
    attitude_why_t own = 0;
    if (product != NULL) { /* compared with the window's own estimate, every window */
        /* only a filter that outlives its windows has moved with the plate; a tumbling
         * one that disagrees with its window is wrong, and its sd says by how much */
        bool moved = false;
        bool *ask = st->cfg.mode == ATTITUDE_SLIDING ? &moved : NULL;
        lag_a = kalman_lag_udeg(st, &product->alpha, ke.alpha_udeg, ke.alpha_sigma_udeg, 0u, ask);
        lag_b = kalman_lag_udeg(st, &product->beta, ke.beta_udeg, ke.beta_sigma_udeg, 1u, ask);
        own = moved ? ATTITUDE_WHY_MOTION : 0u;
    }
    fix_q32_t p00 = ke.p_mm2[0][0] > 0 ? ke.p_mm2[0][0] : window_white_dist(st);
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
        const fix_q32_t d = window_white_dist(st);
        p00 = d > p00 ? d : p00;
    }
    settle(st, e, white_a, white_b, p00, lag_a, lag_b, own);
}

static void disabled(struct attitude_estimate *e, const struct window_stats *w) {
    common_fields(w, e);
    e->reason = ATTITUDE_REASON_DISABLED;
    finish_status(e, false, false);
    e->reason = ATTITUDE_REASON_DISABLED;
    e->why = ATTITUDE_WHY_REASON(ATTITUDE_REASON_DISABLED);
}

/* After a restart the filter's estimate no longer contains the window's earlier
 * readings: they stop counting as used (their rejections still count). */
static void forget_kalman_used(struct attitude_state *st) {
    for (uint16_t age = 0; age < window_fill(&st->window); ++age) {
        struct window_row *row = window_row_at(&st->window, age);
        row->aux = AUX_MAKE(0u, AUX_REJECTED(row->aux));
    }
}

/* A restart while processing the newest row: the row count restarts with it. */
static void note_kalman_restart(struct attitude_state *st) {
    forget_kalman_used(st);
    st->kalman_rows_since_restart = 0;
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

/* The window-end work: statistics and the four estimators. Not inlined, so that its
 * large frame (consensus results, the paper's matrices) does not sit under the per-row
 * Kalman path's stack. */
FIX_NOINLINE void window_end(struct attitude_state *st, struct attitude_output *out) {
    const struct attitude_config *cfg = &st->cfg;
    const bool kalman_on =
        (cfg->estimators & ATTITUDE_EST_BUILT & ATTITUDE_EST_BIT(ATTITUDE_EST_KALMAN)) != 0u;
    window_compute(&st->window, &st->stats);
    const struct window_stats *w = &st->stats;
    /* the drift learning takes one window per block of N rows (every window when tumbling) */
    integrity_assess(&st->integrity, &st->icfg, &st->window, w, st->rows % cfg->window == 0u,
                     &st->iw);
    /* what the window adds to every estimator's angles, as 1σ: computed once */
    st->extra_udeg[0] = angle_sd(st, st->iw.extra_var_mm2[INTEGRITY_ALPHA], 0u);
    st->extra_udeg[1] = angle_sd(st, st->iw.extra_var_mm2[INTEGRITY_BETA], 1u);
    out->last_row = st->rows - 1u;
    out->first_row = st->rows - cfg->window;
    out->rows = cfg->window;

    struct consensus_product_result product;
    (void)memset(&product, 0, sizeof product);
    /* masked with the build's set, so the compiler drops what is not built */
    const uint8_t want = cfg->estimators & ATTITUDE_EST_BUILT;
    /* the Kalman filter is checked against the product's window estimate */
    const bool need_product = (want & (ATTITUDE_EST_BIT(ATTITUDE_EST_CONSENSUS) |
                                       ATTITUDE_EST_BIT(ATTITUDE_EST_PAPER))) != 0u ||
                              kalman_on;
    struct attitude_estimate scratch;
    (void)memset(&scratch, 0, sizeof scratch);
    if (need_product) {
        run_product(st, &product, &scratch);
    }
    if ((want & ATTITUDE_EST_BIT(ATTITUDE_EST_CONSENSUS)) != 0u) {
        out->est[ATTITUDE_EST_CONSENSUS] = scratch;
    } else {
        disabled(&out->est[ATTITUDE_EST_CONSENSUS], w);
    }
    if ((want & ATTITUDE_EST_BIT(ATTITUDE_EST_PAPER)) != 0u) {
        run_paper(st, &product, &out->est[ATTITUDE_EST_PAPER]);
    } else {
        disabled(&out->est[ATTITUDE_EST_PAPER], w);
    }
    if (kalman_on) {
        run_kalman(st, &product, &out->est[ATTITUDE_EST_KALMAN]); /* need_product holds */
    } else {
        disabled(&out->est[ATTITUDE_EST_KALMAN], w);
    }
    if ((want & ATTITUDE_EST_BIT(ATTITUDE_EST_MEAN)) != 0u) {
        run_mean(st, &out->est[ATTITUDE_EST_MEAN]);
    } else {
        disabled(&out->est[ATTITUDE_EST_MEAN], w);
    }

    /* R follows each sensor's noise: once per block of N rows */
    if (kalman_on && st->rows % cfg->window == 0u) {
        bool guess_off = false;
        for (unsigned k = 0; k < ATTITUDE_SENSORS; ++k) {
            guess_off =
                kalman_track_noise(&st->kalman, k, w->sensor[k].var_mm2, w->sensor[k].used) ||
                guess_off;
        }
        /* A filter that outlives its window (sliding, or tracking with Q > 0) weighed and
         * gated the rows so far with the configured R; when the first window's noise
         * says that guess was off by more than 2x, those rows are over- or under-weighted
         * for good (a VL53L1X at 2.5 m read 7.3 mm against the 2 mm guess: its first 100
         * rows, gated at 10 mm, counted 13x and held the estimate 1.8° off): start again
         * with the learnt R. A tumbling filter with Q = 0 restarts every window anyway. */
        if (guess_off && (cfg->mode == ATTITUDE_SLIDING || st->kalman.process_noise)) {
            st->kalman_restart_due = true; /* before the next row: this estimate stands */
        }
    }
}

bool attitude_push_sample(struct attitude_state *st, const uint16_t range_mm[ATTITUDE_SENSORS],
                          const uint8_t range_status[ATTITUDE_SENSORS],
                          const bool present[ATTITUDE_SENSORS], struct attitude_output *out) {
    const struct attitude_config *cfg = &st->cfg;
    const bool kalman_on =
        (cfg->estimators & ATTITUDE_EST_BUILT & ATTITUDE_EST_BIT(ATTITUDE_EST_KALMAN)) != 0u;
    uint8_t present_mask = 0;
    uint8_t valid_mask = 0;
    uint16_t ranges[ATTITUDE_SENSORS];
    for (unsigned k = 0; k < ATTITUDE_SENSORS; ++k) {
        ranges[k] = present[k] ? range_mm[k] : 0u; /* an absent reading carries nothing */
        if (present[k]) {
            present_mask = (uint8_t)(present_mask | (1u << k));
            if (range_status[k] == 0u) {
                valid_mask = (uint8_t)(valid_mask | (1u << k));
            }
        }
    }
    /* 0, no-target values and readings beyond the mode's range are never used, whatever
     * their status: the window answers from the other sensors */
    valid_mask &= (uint8_t)~integrity_implausible(ranges, present_mask, cfg->range_max_mm);
    if (st->kalman_restart_due) { /* the last window found the configured R wrong */
        st->kalman_restart_due = false;
        kalman_reset(&st->kalman);
        st->kalman.restarts++;
        note_kalman_restart(st); /* before this row: it is the filter's first */
    }
    if (st->kalman_rows_since_restart < UINT32_MAX) {
        st->kalman_rows_since_restart++;
    }
    if (cfg->mode == ATTITUDE_TUMBLING && st->rows % cfg->window == 0u) {
        window_clear(&st->window);
        if (!st->kalman.process_noise) { /* with Q > 0 the filter tracks across windows */
            kalman_reset(&st->kalman);
        }
    }
    struct window_row *newest = window_push(&st->window, ranges, present_mask, valid_mask);
    if (kalman_on) {
        const uint32_t restarts = st->kalman.restarts;
        struct kalman_rows rows;
        kalman_push_row(&st->kalman, ranges, valid_mask, &rows);
        record_kalman_rows(st, &rows, newest);
        if (st->kalman.restarts != restarts) {
            note_kalman_restart(st);
        }
    }
    st->rows++;
    const bool ready = cfg->mode == ATTITUDE_TUMBLING ? st->rows % cfg->window == 0u
                                                      : window_fill(&st->window) == cfg->window;
    if (!ready) {
        return false;
    }
    if (kalman_on && cfg->mode == ATTITUDE_TUMBLING) {
        /* a static window ends here: rows still buffered (a restart late in the
         * window, or N below the warm-up) are processed now */
        const uint32_t restarts = st->kalman.restarts;
        struct kalman_rows rows;
        kalman_flush(&st->kalman, &rows);
        record_kalman_rows(st, &rows, NULL);
        if (st->kalman.restarts != restarts) {
            note_kalman_restart(st);
        }
    }
    window_end(st, out);
    return true;
}

const char *attitude_estimator_name(enum attitude_estimator e) {
    switch (e) {
    case ATTITUDE_EST_CONSENSUS:
        return "consensus";
    case ATTITUDE_EST_PAPER:
        return "consensus-paper";
    case ATTITUDE_EST_KALMAN:
        return "kalman";
    case ATTITUDE_EST_MEAN:
        return "mean";
    default:
        return "unknown";
    }
}

const char *attitude_status_name(enum attitude_status s) {
    switch (s) {
    case ATTITUDE_OK:
        return "ok";
    case ATTITUDE_DEGRADED:
        return "degraded";
    case ATTITUDE_INVALID:
        return "invalid";
    default:
        return "unknown";
    }
}

const char *attitude_reason_name(enum attitude_reason r) {
    static const char *const names[ATTITUDE_REASON_COUNT] = {
        "none",
        "flagged-data",
        "sensor-missing",
        "kalman-restarted",
        "alpha-unobservable",
        "beta-unobservable",
        "unobservable",
        "disabled",
        "no-convergence",
        "paper-too-few-rows",
        "paper-nonpositive-variance",
        "paper-zero-covariance",
        "paper-zero-row-sum",
        "paper-negative-row-sum",
        "paper-overflow",
        "paper-diverged",
        "paper-no-convergence",
        "paper-outside-hull",
        "paper-inconsistent",
    };
    if ((unsigned)r >= (unsigned)ATTITUDE_REASON_COUNT) {
        return "unknown";
    }
    return names[r];
}

/* Appends "+name" (no '+' first) with an optional ":X" sensor letter; false when full. */
static bool why_append(char *buf, size_t cap, size_t *len, const char *name, char sensor) {
    size_t need = (*len != 0u ? 1u : 0u) + strlen(name) + (sensor != '\0' ? 2u : 0u);
    if (*len + need + 1u > cap) {
        return false;
    }
    if (*len != 0u) {
        buf[*len] = '+';
        (*len)++;
    }
    for (const char *c = name; *c != '\0'; ++c) {
        buf[*len] = *c;
        (*len)++;
    }
    if (sensor != '\0') {
        buf[*len] = ':';
        (*len)++;
        buf[*len] = sensor;
        (*len)++;
    }
    buf[*len] = '\0';
    return true;
}

int attitude_why_format(attitude_why_t why, char *buf, size_t cap) {
    static const char *const per_sensor[5] = {"no-target", "range", "flagged", "missing",
                                              "rejected"};
    static const char *const window[3] = {"parity", "motion", "drift"};
    if (buf == NULL || cap == 0u) {
        return buf == NULL ? ATTITUDE_ERR_NULL : ATTITUDE_ERR_BUFFER;
    }
    size_t len = 0;
    buf[0] = '\0';
    bool fits = true;
    for (unsigned g = 0; g < 5u && fits; ++g) {
        for (unsigned k = 0; k < ATTITUDE_SENSORS && fits; ++k) {
            if ((why & ((attitude_why_t)1u << (4u * g + k))) != 0u) {
                fits = why_append(buf, cap, &len, per_sensor[g], (char)('A' + k));
            }
        }
    }
    for (unsigned b = 0; b < 3u && fits; ++b) {
        if ((why & (ATTITUDE_WHY_PARITY << b)) != 0u) {
            fits = why_append(buf, cap, &len, window[b], '\0');
        }
    }
    for (unsigned r = 1; r < (unsigned)ATTITUDE_REASON_COUNT && fits; ++r) {
        if ((why & ATTITUDE_WHY_REASON(r)) != 0u) {
            fits = why_append(buf, cap, &len, attitude_reason_name((enum attitude_reason)r), '\0');
        }
    }
    if (!fits) {
        buf[0] = '\0';
        return ATTITUDE_ERR_BUFFER;
    }
    return (int)len;
}
