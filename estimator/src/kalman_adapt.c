/* The Kalman filter's process_noise_auto: Q and R learned from the readings (kalman_internal.h). */
#include "kalman_internal.h"

/* What each state does over time is read off the readings themselves, not the filter's
 * innovations (whose variance hides a small q under R: the slow-motion case needs ~10^7
 * rows that way). Per row with all four readings, the transformed sums
 *     y_x̄ = z_A + z_B + z_C + z_D = 4 x̄ + noise,  y_α = z_C − z_A = 2 θ_α + noise,
 *     y_β = z_B − z_D = 2 θ_β + noise
 * are summed over blocks of B rows. For a random walk of intensity q_y per row plus white
 * noise of variance w_y per row, the difference D of two consecutive block sums has
 * E[D²] = q_y · B(2B² + 1)/3 + 2B · w_y (the Allan variance of the block means, times B²:
 * each increment of the walk enters D with weight min(t, 2B − t)), and the sum S of the
 * squared row differences (Δy)² over the same 2B rows has E[S] = 2B(2w_y + q_y), so
 *     q_y = E[D² − S/2] / (B(2B² + 1)/3 − B)
 * whatever w_y: each block's noise is taken from its own rows (subtracting the
 * learnt R instead biased the samples by its own error, up to 25 %, times the noise/q
 * ratio, 360 at B = 32 for q_t 0.01 mm²/s at σ 7 mm). q_y = 16 q_x̄, 4 q_t, 4 q_t: one block
 * gives a sample of q_x̄ and of q_t (both slopes share it, as --process-noise QD,QT does).
 * Which B: a sample's sd is about its mean, q + 3w/B² per row, so a short block drowns a
 * slow walk in noise (there: 360 x q at B = 32, 22 x at 128, 1.4 x at 512) and the best B
 * is about √(3w/q) (600 rows there), while fast motion wants short blocks (more samples).
 * So four lengths run at once, B = 32, 128, 512, 2 048 rows (a cascade: each level's sum
 * is four of the level below), each with its running mean (gain 1/2^⌊log2 n⌋, then 2^-6
 * a sample: memory 64 blocks, i.e. it grows with B). Q is their inverse-variance mean,
 * weights n_l/(q + noise_l)², every level from its first sample, q from two steps of that
 * mean's fixed point (the first from the q in use), and at least a quarter of the mean's
 * own sd (a q learnt as 0 freezes the filter: the costliest miss); set at each 32-row
 * block's end, when it moved by more than a factor 1.5. A hundredfold fall of q would stay
 * in the long levels' means for thousands of rows: a test per level detects it
 * (adapt_fall) and the group's levels start again. A sample is bounded to ±64 mm² per row;
 * a block difference of 1 024 mm a row or more, a jump, not used; a row without all four
 * readings restarts the blocks of every level.
 * R comes from what the motion barely touches: the difference d of a sensor's consecutive
 * readings has E[d²] = 2R + hQhᵀ = 2R + Q_x̄ + Q_t (h has entries ±1), so
 * R = (E[d²] − Q_x̄ − Q_t)/2, at least 1/12 mm² (a difference of 128 mm or more, a jump,
 * not used); the d² summed over 32 differences, then a running mean of those sums (gain
 * 1/2^⌊log2 n⌋, then 2^-4: 512 rows). Cost: about 40 instructions a row; every 32 rows
 * (and rarer for longer blocks) three 64-bit divisions and the fall test per level that
 * ends, and the levels' mean twice per group (32-bit divisions, two 64-bit ones, a square
 * root by Newton). Memory: 4 levels x (4 x 3 block sums + 2 means + 2 tests) words. */
#define KALMAN_ADAPT_BLOCK   32u
#define KALMAN_ADAPT_FAN     4u /* sub-blocks per block above level 0 */
#define KALMAN_ADAPT_Q_SHIFT 6u
#define KALMAN_ADAPT_R_SHIFT 4u
/* Q is set anew when the learnt value moves by more than a factor 12/8 (a q off by 1.5
 * costs the filter 1 % of RMS error at most; each change ends the steady state) */
#define KALMAN_ADAPT_HYST    12
#define KALMAN_ADAPT_ITER    2u   /* steps of the levels' mean per block (adapt_choose) */
#define KALMAN_ADAPT_FALL_N  16u  /* the fall test (adapt_fall): armed from this many samples */
#define KALMAN_ADAPT_LN16_Q8 710  /* ln 16 in Q8 */
#define KALMAN_ADAPT_FALL_H  2560 /* 10 in Q8 */

/* B(B² − 1)/24 = (B(2B² + 1)/3 − B)/16 (exact) */
static const int64_t adapt_weight16b[KALMAN_ADAPT_LEVELS] = {1364, 87376, 5592384, 357913856};

/* mean += (v − mean) · gain, the gain from the samples so far (|v|, |mean| < 2^30) */
static void adapt_mean(int32_t *mean, int32_t v, uint16_t n, unsigned max_shift) {
    const unsigned g = fix_bitlen_u64(n) - 1u; /* n >= 1 */
    const unsigned sh = g < max_shift ? g : max_shift;
    const int64_t step = (int64_t)v - *mean;
    /* rounded: a floor would bias the mean by half a unit times 2^shift */
    *mean += (int32_t)(sh == 0u ? step : fix_round_shr_s64(step, sh));
}

/* The white-noise part of E[D²]/(B(2B² + 1)/3) at level 0: 2B·w/(B(2B² + 1)/3) =
 * 6w/2049, Q32 mm² per row (w in Q32, below 2^55), by a multiplication: 6·2^22/2049 is
 * 12 282 to 10^-6. */
static int64_t adapt_noise0(int64_t w_q32) {
    return ((w_q32 >> 8) * 12282) >> 14;
}

/* One block's sample of q_y in Q16 mm² per row, from D and the sum S of (Δy)² over the
 * same 2B rows: E[(Δy)²] = 2w + q_y, so E[D² − S/2] = q_y (B(2B² + 1)/3 − B) whatever w. */
static int64_t adapt_q_sample(unsigned l, int32_t d, uint32_t dsq) {
    const int64_t d2 = ((int64_t)d * d - (int64_t)(dsq >> 1)) * 4096; /* |d| < 2^(15+2l) */
    return fix_div_trunc_s64(d2, adapt_weight16b[l]);
}

static int32_t adapt_bound(int64_t v) {
    const int64_t lim = (int64_t)1 << 30; /* 64 mm² in Q24 */
    return (int32_t)(v > lim ? lim : (v < -lim ? -lim : v));
}

/* A fall of q: the running means forget at 2^-6 a sample, 2 000 rows at level
 * 0 and 4^l times that above, so after q falls a hundredfold the old q stays in them for
 * thousands of rows. Each level and group runs a CUSUM test of "this sample's D² is what
 * the level's mean predicts" against "a sixteenth of it": x = D²/E[D²] with
 * E[D²] = q̄·(c_B − B) + S/2 (q̄ the level's mean, S the sample's own (Δy)² sum), one χ²
 * draw per axis (one for x̄, two for the slopes), log-likelihood ratio per sample
 * k/2·(ln 16 − 15 x) for k axes, summed and floored at 0. Past 10 every level of the group
 * forgets (its samples start again). Measured (ref_tracking --trace): after
 * q_t 1 -> 0.01 mm²/s at σ 3 mm, found 580 to 1 350 rows later; on stationary walks, one
 * false alarm in 18 runs of 20 000 rows. Armed once a level has 16 samples. */
static void adapt_fall(struct kalman_cov *cv, unsigned l, unsigned g,
                       const int32_t d[KALMAN_STATES], const uint32_t dsq[KALMAN_STATES]) {
    if (cv->n_q[l][g] < KALMAN_ADAPT_FALL_N) {
        return;
    }
    const int64_t w = adapt_weight16b[l];
    const int64_t m = cv->mean_q[l][g] > 0 ? cv->mean_q[l][g] : 0; /* Q24 of the state */
    uint64_t num;
    int64_t den;
    if (g == 0u) {
        const int64_t sq0 = (int64_t)d[0] * d[0];
        num = (uint64_t)sq0;
        den = ((m * w) >> 16) + (int64_t)(dsq[0] >> 1); /* q_y = 16 q_x̄, Q16 = m/16 */
    } else {
        const int64_t sq1 = (int64_t)d[1] * d[1];
        const int64_t sq2 = (int64_t)d[2] * d[2];
        num = (uint64_t)sq1 + (uint64_t)sq2;
        den = ((m * w) >> 17) + (int64_t)(dsq[1] >> 1) + (int64_t)(dsq[2] >> 1); /* 2 x 4 q_t */
    }
    /* x in Q8 from 16-bit den (32-bit division), at most 255 (the test's step is then far
     * below 0 anyway) */
    const unsigned sh =
        fix_bitlen_u64((uint64_t)den) > 16u ? fix_bitlen_u64((uint64_t)den) - 16u : 0u;
    const uint32_t den16 = (uint32_t)((uint64_t)den >> sh) | 1u;
    const uint64_t num_s = num >> sh;
    const uint32_t ratio_q8 = num_s >= ((uint64_t)den16 << 8)
                                  ? 255u * 256u
                                  : (((uint32_t)num_s << 8) / den16); /* below 2^16 */
    const int32_t x = (int32_t)ratio_q8;
    int32_t k = 2;
    if (g == 0u) {
        k = 1;
    }
    int32_t c = cv->fall[l][g] + k * (KALMAN_ADAPT_LN16_Q8 - 15 * x) / 2;
    c = c > 0 ? c : 0;
    if (c > KALMAN_ADAPT_FALL_H) {
        for (unsigned i = 0; i < KALMAN_ADAPT_LEVELS; ++i) {
            cv->n_q[i][g] = 0;
            cv->fall[i][g] = 0;
        }
        return;
    }
    cv->fall[l][g] = c;
}

/* The end of a block of level l: samples of q from the difference to the block before. */
static void adapt_block(struct kalman_cov *cv, unsigned l) {
    int32_t d[KALMAN_STATES];
    uint32_t dsq[KALMAN_STATES];
    bool usable = (cv->blk_prev_valid & (1u << l)) != 0u;
    const int32_t lim = (int32_t)1 << (15u + 2u * l); /* 1 024 mm a row: a jump */
    for (unsigned j = 0; j < KALMAN_STATES; ++j) {
        d[j] = cv->blk_sum[l][j] - cv->blk_prev[l][j];
        usable = usable && d[j] < lim && d[j] > -lim;
        dsq[j] = cv->blk_dsq[l][j] + cv->blk_dsq_prev[l][j];
        cv->blk_prev[l][j] = cv->blk_sum[l][j];
        cv->blk_sum[l][j] = 0;
        cv->blk_dsq_prev[l][j] = cv->blk_dsq[l][j];
        cv->blk_dsq[l][j] = 0;
    }
    cv->blk_prev_valid |= (uint8_t)(1u << l);
    cv->blk_sub[l] = 0;
    if (!usable) {
        return;
    }
    int64_t qy[KALMAN_STATES];
    for (unsigned j = 0; j < KALMAN_STATES; ++j) {
        qy[j] = adapt_q_sample(l, d[j], dsq[j]);
    }
    /* Q16 of q_y to Q24 of the state: x̄ q_y/16, slopes q_y/4 (their mean) */
    const int32_t v[2] = {adapt_bound(qy[0] * 16), adapt_bound((qy[1] + qy[2]) * 32)};
    for (unsigned g = 0; g < 2u; ++g) {
        adapt_fall(cv, l, g, d, dsq);
        uint16_t *n = &cv->n_q[l][g];
        *n = *n < UINT16_MAX ? (uint16_t)(*n + 1u) : UINT16_MAX;
        adapt_mean(&cv->mean_q[l][g], v[g], *n, KALMAN_ADAPT_Q_SHIFT);
    }
}

/* ⌊√v⌋ to within one: Newton's iteration from above (2^⌈bits/2⌉), four 32-bit divisions
 * (the floor below needs a few digits; fix_isqrt_u64's 32 rounds cost 60 instructions a row
 * here) */
static uint32_t adapt_sqrt32(uint32_t v) {
    if (v == 0u) {
        return 0u;
    }
    uint32_t x = (uint32_t)1 << ((fix_bitlen_u64(v) + 1u) / 2u);
    for (unsigned i = 0; i < 4u; ++i) {
        x = (x + v / x) / 2u;
    }
    return x;
}

/* Q of state group g (0 x̄, 1 slopes), Q32 mm² per row: the levels' means weighted by
 * n_l/(q + noise_l)² (a sample's sd is about its mean E[D²]/weight, q + noise_l), q the
 * current value: long blocks weigh most for slow motion, short ones (more samples) for
 * fast. */
static int64_t adapt_choose(const struct kalman_cov *cv, unsigned g, int64_t q_now,
                            const int64_t nz0[KALMAN_STATES]) {
    uint64_t s[KALMAN_ADAPT_LEVELS];
    uint64_t top = 1;
    for (unsigned l = 0; l < KALMAN_ADAPT_LEVELS; ++l) {
        /* the noise in the state's units (x̄ q_y/16, each slope q_y/4, the mean of two);
         * level l's is level 0's / 16^l to 0.1 % ((2B² + 1) grows 16-fold a level): shifts,
         * no division */
        const int64_t nz = (g == 0u ? nz0[0] / 16 : (nz0[1] + nz0[2]) / 8) >> (4u * l);
        s[l] = (uint64_t)(q_now > 0 ? q_now : 0) + (uint64_t)nz + 1u;
        top = s[l] > top ? s[l] : top;
    }
    const unsigned bl = fix_bitlen_u64(top);
    const unsigned sh = bl > 11u ? bl - 11u : 0u; /* s below 2^11: 32-bit divisions */
    int64_t num = 0;
    int64_t den = 0;
    for (unsigned l = 0; l < KALMAN_ADAPT_LEVELS; ++l) {
        /* the running mean's memory caps the samples a level counts; every level counts
         * from its first sample (waiting for 8 left slow tilt to level 0 alone, whose
         * noise is 360 x q_t at 0.01 mm²/s and σ 7 mm, for 4 600 rows) */
        const uint32_t cap = 2u << KALMAN_ADAPT_Q_SHIFT;
        const uint32_t n = cv->n_q[l][g] < cap ? (uint32_t)cv->n_q[l][g] : cap;
        const uint32_t sl = (uint32_t)(s[l] >> sh) | 1u;
        const uint32_t wl = (n << 23) / (sl * sl); /* 2n to 2^30 */
        num += (int64_t)wl * cv->mean_q[l][g];     /* sums below 2^62 */
        den += (int64_t)wl;
    }
    if (den <= 0) {
        return 0; /* no level has a sample (the start, or all forgot a fall) */
    }
    const int64_t mean = fix_div_trunc_s64(num, den);
    const int64_t m = mean > 0 ? mean << 8 : 0;
    /* at least a quarter of the mean's sd, sqrt(2/Σ n_l/s_l²)/4 = 2^sh·sqrt(2^24/den)/4:
     * a q learnt as 0 would freeze the filter, the worst miss (its cost grows with
     * |log q̂/q|) */
    const uint64_t v = ((uint64_t)1 << 56) / (uint64_t)den; /* den below 2^32 */
    const unsigned vb = fix_bitlen_u64(v);
    const unsigned r = vb > 32u ? (vb - 31u) / 2u : 0u; /* v >> 2r below 2^32 */
    const int64_t sd = ((int64_t)adapt_sqrt32((uint32_t)(v >> (2u * r))) << (sh + r)) >> 18;
    return m > sd ? m : sd;
}

/* A learnt value moved enough to be worth a new fixed point: by more than a quarter (a q
 * or R off by 25 % changes the filter's RMS error by about 0.3 %), while each change ends
 * the steady state (kalman_steady.c) and its cheap rows. */
static bool adapt_moved(int64_t now, int64_t next) {
    const int64_t d = next > now ? next - now : now - next;
    return d > (now >> 2) || (now == 0) != (next == 0);
}

/* A learnt q moved by more than a factor HYST/8 either way (Q32 values below 2^56). */
static bool adapt_q_moved(int64_t now, int64_t next) {
    return next * 8 > now * KALMAN_ADAPT_HYST || now * 8 > next * KALMAN_ADAPT_HYST ||
           (now == 0) != (next == 0);
}

/* A full row into the block sums of every level; the blocks that end are sampled and Q
 * set. */
static uint32_t adapt_sq(int32_t v) {
    const int32_t lim = 512; /* a jump: the block difference says so */
    const int32_t c = v < lim && v > -lim ? v : lim;
    const int32_t sq = c * c; /* below 2^18 */
    return (uint32_t)sq;
}

static void adapt_sums(struct kalman_state *k, const uint16_t range_mm[ANGLES_SENSORS],
                       const int32_t dz[ANGLES_SENSORS]) {
    struct kalman_cov *cv = &k->cov;
    cv->blk_dsq[0][0] += adapt_sq(dz[0] + dz[1] + dz[2] + dz[3]); /* below 2^29 */
    cv->blk_dsq[0][1] += adapt_sq(dz[ANGLES_C] - dz[ANGLES_A]);
    cv->blk_dsq[0][2] += adapt_sq(dz[ANGLES_B] - dz[ANGLES_D]);
    const int32_t za = range_mm[ANGLES_A];
    const int32_t zb = range_mm[ANGLES_B];
    const int32_t zc = range_mm[ANGLES_C];
    const int32_t zd = range_mm[ANGLES_D];
    cv->blk_sum[0][0] += za + zb + zc + zd; /* 2 048 rows: below 2^29 */
    cv->blk_sum[0][1] += zc - za;
    cv->blk_sum[0][2] += zb - zd;
    if (++cv->blk_sub[0] < KALMAN_ADAPT_BLOCK) {
        return;
    }
    const fix_q32_t *r = k->r;
    const int64_t w[KALMAN_STATES] = {r[0] + r[1] + r[2] + r[3], r[ANGLES_A] + r[ANGLES_C],
                                      r[ANGLES_B] + r[ANGLES_D]};
    for (unsigned l = 0; l < KALMAN_ADAPT_LEVELS; ++l) {
        if (l + 1u < KALMAN_ADAPT_LEVELS) {
            for (unsigned j = 0; j < KALMAN_STATES; ++j) {
                cv->blk_sum[l + 1u][j] += cv->blk_sum[l][j];
                cv->blk_dsq[l + 1u][j] += cv->blk_dsq[l][j];
            }
        }
        adapt_block(cv, l);
        if (l + 1u == KALMAN_ADAPT_LEVELS || ++cv->blk_sub[l + 1u] < KALMAN_ADAPT_FAN) {
            break;
        }
    }
    fix_q32_t *q = k->cfg.process_noise_mm2;
    const int64_t nz0[KALMAN_STATES] = {adapt_noise0(w[0]), adapt_noise0(w[1]), adapt_noise0(w[2])};
    int64_t qx = q[0];
    int64_t qt = q[1];
    for (unsigned it = 1; it <= KALMAN_ADAPT_ITER; ++it) {
        qx = adapt_choose(cv, 0, qx, nz0);
        qt = adapt_choose(cv, 1, qt, nz0);
    }
    if (adapt_q_moved(q[0], qx) || adapt_q_moved(q[1], qt)) {
        q[0] = qx;
        q[1] = qt;
        q[2] = qt;
        cv->steady = false; /* the fixed point moved */
    }
}

bool kalman_adapt_row(struct kalman_state *k, const uint16_t range_mm[ANGLES_SENSORS],
                      uint8_t valid_mask) {
    struct kalman_cov *cv = &k->cov;
    const uint8_t both = (uint8_t)(valid_mask & cv->last_valid);
    const bool follows = cv->last_valid == ANGLES_ALL_SENSORS; /* dz below is whole */
    int32_t dz[ANGLES_SENSORS];
    for (unsigned s = 0; s < ANGLES_SENSORS; ++s) {
        const int32_t d = (int32_t)range_mm[s] - (int32_t)cv->last_mm[s];
        dz[s] = d;
        if ((both & (1u << s)) != 0u && d < 128 && d > -128) {
            const int32_t sq = d * d;
            cv->sum_d2[s] += (uint32_t)sq; /* 32 rows: below 2^19 */
            if (++cv->cnt_d[s] == KALMAN_ADAPT_BLOCK) {
                /* 32 differences' mean into the running mean: gain 1/2^⌊log2 n⌋, then
                 * 2^-4 a block (512 rows) */
                cv->n_d[s] = cv->n_d[s] < UINT8_MAX ? (uint8_t)(cv->n_d[s] + 1u) : UINT8_MAX;
                adapt_mean(&cv->mean_d[s], (int32_t)(cv->sum_d2[s] << 11), cv->n_d[s],
                           KALMAN_ADAPT_R_SHIFT);
                cv->sum_d2[s] = 0;
                cv->cnt_d[s] = 0;
            }
        }
        cv->last_mm[s] = range_mm[s];
    }
    cv->last_valid = valid_mask;
    if (valid_mask != ANGLES_ALL_SENSORS || !follows) {
        /* a block is consecutive full rows, each with the difference to the one before:
         * start again */
        cv->blk_prev_valid = 0;
        for (unsigned l = 0; l < KALMAN_ADAPT_LEVELS; ++l) {
            cv->blk_sub[l] = 0;
            for (unsigned j = 0; j < KALMAN_STATES; ++j) {
                cv->blk_sum[l][j] = 0;
                cv->blk_dsq[l][j] = 0;
            }
        }
        return false;
    }
    adapt_sums(k, range_mm, dz);
    if (cv->blk_sub[0] != 0u) {
        return false;
    }
    const fix_q32_t *q = k->cfg.process_noise_mm2;
    bool r_set = false;
    for (unsigned s = 0; s < ANGLES_SENSORS; ++s) {
        if (cv->mean_d[s] > 0) {
            const int64_t v = (((int64_t)cv->mean_d[s] << 16) - q[0] - q[1]) / 2;
            const int64_t r = v < KALMAN_R_MIN_Q32 ? KALMAN_R_MIN_Q32 : v; /* below 2^13 mm² */
            if (adapt_moved(k->r[s], r)) {
                k->r[s] = r;
                r_set = true;
            }
        }
    }
    return r_set;
}
