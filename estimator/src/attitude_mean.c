/* The plain mean estimate of a window: the average of the angle estimates available. */
#include "attitude_internal.h"

static const uint8_t bit_a = ANGLES_BIT(ANGLES_A);
static const uint8_t bit_b = ANGLES_BIT(ANGLES_B);
static const uint8_t bit_c = ANGLES_BIT(ANGLES_C);
static const uint8_t bit_d = ANGLES_BIT(ANGLES_D);

/* α needs A and C, or B and D plus one of A, C (docs/explanation/architecture.md model, rank of H).
 */
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

static uint8_t sensors_used(const struct attitude_estimate *e) {
    uint8_t m = 0;
    for (unsigned k = 0; k < ATTITUDE_SENSORS; ++k) {
        if (e->counts[k].used != 0u) {
            m = (uint8_t)(m | (1u << k));
        }
    }
    return m;
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

void attitude_run_mean(struct attitude_state *st, struct attitude_estimate *e) {
    const struct window_stats *w = &st->stats;
    attitude_common_fields(w, e);
    const uint8_t s = sensors_used(e);
    e->alpha_udeg = mean_of_angles(&w->alpha);
    e->beta_udeg = mean_of_angles(&w->beta);
    e->distance_valid = attitude_pair_midpoints_um(w, &e->distance_um);
    attitude_finish_status(e, alpha_observable(s), beta_observable(s));
    attitude_settle(st, e, attitude_angle_sd(st, mean_white_var(st, &w->alpha, false), 0u),
                    attitude_angle_sd(st, mean_white_var(st, &w->beta, true), 1u),
                    attitude_window_white_dist(st), 0, 0, 0u);
}
