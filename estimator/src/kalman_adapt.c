/* The Kalman filter's process_noise_auto: Q and R learned from the readings (kalman_adapt.h). */
#include "kalman_adapt.h"

#include "fix_inline.h"

/* What each state does over time is read off the readings themselves, not the filter's
 * innovations (whose variance hides a small q under R: the slow-motion case needs ~10^7
 * rows that way). Per row with all four readings, the transformed sums
 *     y_x̄ = z_A + z_B + z_C + z_D = 4 x̄ + noise,  y_α = z_C − z_A = 2 θ_α + noise,
 *     y_β = z_B − z_D = 2 θ_β + noise
 * are summed over blocks of B = KALMAN_ADAPT_BLOCK rows. For a random walk of intensity
 * q_y per row plus white noise of variance w_y per row, the difference D of two
 * consecutive block sums has E[D²] = q_y · B(2B² + 1)/3 + 2B · w_y (the Allan variance of
 * the block means, times B²: each increment of the walk enters D with weight
 * min(t, 2B − t)). With w_x̄ = ΣR, w_α = R_A + R_C, w_β = R_B + R_D and q_y = 16 q_x̄,
 * 4 q_t, 4 q_t, one block gives a sample of q_x̄ and of q_t (both slopes share it, as
 * --process-noise QD,QT does); their running means set Q at each block's end (Q at least
 * 0, a sample bounded to ±64 mm² per row, a block difference of 2^15 mm or more, a jump,
 * not used).
 * R comes from what the motion barely touches: the difference d of a sensor's consecutive
 * readings has E[d²] = 2R + hQhᵀ = 2R + Q_x̄ + Q_t (h has entries ±1), so
 * R = (E[d²] − Q_x̄ − Q_t)/2, at least 1/12 mm² (a difference of 128 mm or more, a jump,
 * not used). Running means: gain 1/2^⌊log2 n⌋ over the first samples, then 2^-6 per
 * block for q (about 2,000 rows) and 2^-9 per row for R. Cost: about 20 instructions a
 * row and a few 64-bit divisions a block. */
#define KALMAN_ADAPT_BLOCK   32u
#define KALMAN_ADAPT_Q_SHIFT 6u
#define KALMAN_ADAPT_R_SHIFT 9u
/* B(2B² + 1)/3 for B = 32 */
#define KALMAN_ADAPT_Q_WEIGHT 21856

/* mean += (v − mean) · gain, the gain from the samples so far (|v|, |mean| < 2^30) */
static void adapt_mean(int32_t *mean, int32_t v, uint16_t n, unsigned max_shift) {
    const unsigned g = fix_bitlen_u64(n) - 1u; /* n >= 1 */
    const unsigned sh = g < max_shift ? g : max_shift;
    const int64_t step = (int64_t)v - *mean;
    /* rounded: a floor would bias the mean by half a unit times 2^shift */
    *mean += (int32_t)(sh == 0u ? step : fix_round_shr_s64(step, sh));
}

/* One block's sample of q_y in Q16 mm² per row: (D² − 2B w)/(B(2B² + 1)/3), w in Q32. */
static int64_t adapt_q_sample(int32_t d, int64_t w_q32) {
    const int64_t d2 = ((int64_t)d * d) << 16; /* |d| < 2^15: below 2^46 */
    const int64_t noise = (int64_t)(2u * KALMAN_ADAPT_BLOCK) * (w_q32 >> 16);
    return (d2 - noise) / KALMAN_ADAPT_Q_WEIGHT;
}

static int32_t adapt_bound(int64_t v) {
    const int64_t lim = (int64_t)1 << 30; /* 64 mm² in Q24 */
    return (int32_t)(v > lim ? lim : (v < -lim ? -lim : v));
}

/* The end of a block of full rows: samples of q from the difference to the block before. */
static void adapt_block(struct kalman_state *k) {
    struct kalman_cov *cv = &k->cov;
    const fix_q32_t *r = k->r;
    int32_t d[KALMAN_STATES];
    bool usable = cv->blk_prev_valid;
    for (unsigned j = 0; j < KALMAN_STATES; ++j) {
        d[j] = cv->blk_sum[j] - cv->blk_prev[j];
        usable = usable && d[j] < 32768 && d[j] > -32768;
        cv->blk_prev[j] = cv->blk_sum[j];
        cv->blk_sum[j] = 0;
    }
    cv->blk_prev_valid = true;
    cv->blk_rows = 0;
    if (!usable) {
        return;
    }
    const int64_t w[KALMAN_STATES] = {r[0] + r[1] + r[2] + r[3], r[ANGLES_A] + r[ANGLES_C],
                                      r[ANGLES_B] + r[ANGLES_D]};
    int64_t qy[KALMAN_STATES];
    for (unsigned j = 0; j < KALMAN_STATES; ++j) {
        qy[j] = adapt_q_sample(d[j], w[j]);
    }
    cv->n_q = cv->n_q < UINT16_MAX ? (uint16_t)(cv->n_q + 1u) : UINT16_MAX;
    /* Q16 of q_y to Q24 of the state: x̄ q_y/16, slopes q_y/4 (their mean) */
    adapt_mean(&cv->mean_q[0], adapt_bound(qy[0] * 16), cv->n_q, KALMAN_ADAPT_Q_SHIFT);
    adapt_mean(&cv->mean_q[1], adapt_bound((qy[1] + qy[2]) * 32), cv->n_q, KALMAN_ADAPT_Q_SHIFT);
    fix_q32_t *q = k->cfg.process_noise_mm2;
    q[0] = cv->mean_q[0] > 0 ? (int64_t)cv->mean_q[0] << 8 : 0;
    q[1] = cv->mean_q[1] > 0 ? (int64_t)cv->mean_q[1] << 8 : 0;
    q[2] = q[1];
    cv->steady = false; /* the fixed point moved */
}

bool kalman_adapt_row(struct kalman_state *k, const uint16_t range_mm[ANGLES_SENSORS],
                      uint8_t valid_mask) {
    struct kalman_cov *cv = &k->cov;
    const uint8_t both = (uint8_t)(valid_mask & cv->last_valid);
    if (both != 0u && cv->n_d < UINT16_MAX) {
        cv->n_d++;
    }
    for (unsigned s = 0; s < ANGLES_SENSORS; ++s) {
        const int32_t d = (int32_t)range_mm[s] - (int32_t)cv->last_mm[s];
        if ((both & (1u << s)) != 0u && d < 128 && d > -128) {
            adapt_mean(&cv->mean_d[s], (d * d) << 16, cv->n_d, KALMAN_ADAPT_R_SHIFT);
        }
        cv->last_mm[s] = range_mm[s];
    }
    cv->last_valid = valid_mask;
    if (valid_mask != ANGLES_ALL_SENSORS) {
        /* a block is consecutive full rows: start again */
        cv->blk_rows = 0;
        cv->blk_prev_valid = false;
        for (unsigned j = 0; j < KALMAN_STATES; ++j) {
            cv->blk_sum[j] = 0;
        }
        return false;
    }
    const int32_t za = range_mm[ANGLES_A];
    const int32_t zb = range_mm[ANGLES_B];
    const int32_t zc = range_mm[ANGLES_C];
    const int32_t zd = range_mm[ANGLES_D];
    cv->blk_sum[0] += za + zb + zc + zd; /* 32 rows: below 2^23 */
    cv->blk_sum[1] += zc - za;
    cv->blk_sum[2] += zb - zd;
    if (++cv->blk_rows < KALMAN_ADAPT_BLOCK) {
        return false;
    }
    adapt_block(k);
    const fix_q32_t *q = k->cfg.process_noise_mm2;
    bool r_set = false;
    for (unsigned s = 0; s < ANGLES_SENSORS; ++s) {
        if (cv->mean_d[s] > 0) {
            const int64_t v = (((int64_t)cv->mean_d[s] << 16) - q[0] - q[1]) / 2;
            k->r[s] = v < KALMAN_R_MIN_Q32 ? KALMAN_R_MIN_Q32 : v; /* below 2^13 mm² */
            r_set = true;
        }
    }
    return r_set;
}
