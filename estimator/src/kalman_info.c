/* The Kalman filter's information form (Q = 0): see estimator/kalman.h. */
#include <string.h>

#include "kalman_form.h"

/* --- the information form (Q = 0) ------------------------------------------------------
 * Without process noise the filter is recursive least squares: after any set of accepted
 * readings Y = P⁻¹ = y0·I + Σ_s a_s h_s h_sᵀ and Y(θ̂ − θ0) = Σ_s h_s ζ_s, where a_s is the
 * sum of the weights 1/R_s of sensor s's accepted readings, ζ_s the sum of those weights
 * times the readings' deviations from θ0 = (x0_mm, 0, 0), the prior mean. With the rows h_s
 * (kalman.h) Y is
 *     [ f  c  e ]      f = y0 + a_A + a_B + a_C + a_D
 *     [ c  A  0 ]      c = a_C − a_A,  A = y0 + a_A + a_C
 *     [ e  0  B ]      e = a_B − a_D,  B = y0 + a_B + a_D
 * (no row has both a·tan α and a·tan β, so Y_12 = 0 exactly). Eliminating the two slopes
 * (Schur complement on x̄), with g_α = c/A, g_β = e/B and each axis written as its sensors
 * m ("minus") and p ("plus"): α (A, C), β (D, B):
 *     d   = y0 + Σ_axes (y0(a_m + a_p) + 4 a_m a_p) / Y_jj
 *     δx̄  = Σ_axes ((y0 + 2a_p) ζ_m + (y0 + 2a_m) ζ_p) / Y_jj  /  d
 *     δθ_j = (ζ_p − ζ_m) / Y_jj − g_j δx̄
 *     P   = [ 1/d, −g_α/d, −g_β/d; ·, 1/A + g_α²/d, g_α g_β/d; ·, ·, 1/B + g_β²/d ]
 * Every term of d and of δx̄'s numerator is written without cancellation (the textbook
 * f − c²/A − e²/B and ζ1 − g_α ζα − g_β ζβ would lose the bits of a weak sensor of a pair to
 * it), and d, A, B >= y0 > 0: P is positive definite by construction, nothing to check.
 * Each quotient takes the 31-bit reciprocal of its divisor (relative error below 2^-28) and
 * the divided quantity's own 31-bit mantissa; the sums themselves are exact integers.
 *
 * Units: a weight unit is 2^-e mm⁻² (y0 = 1/P0 = 2^-24 mm⁻² is 2^(e − 24) units), chosen at
 * each start so that the largest weight of one reading is in (2^29, 2^30]; a sensor 2^12
 * times noisier in σ keeps 6 bits of weight. Deviations are whole mm (|dev| < 2^16), each
 * weight · deviation below 2^46: the sums are checked every INFO_CHECK_ROWS rows and, past
 * 2^58 (after ~2^28 readings, or ~2^12 readings 65 m from the start), halved with the
 * weights: one unit coarser, exact but for the dropped bit. */

#define INFO_SUM_CHECK                                                                             \
    ((uint64_t)1 << 58)       /* checked bound of each |sum|: below 2^59 between checks */
#define INFO_CHECK_ROWS 2048u /* 2048 rows add below 2^57 to a sum */
#define INFO_W_SHIFT    (-1)  /* largest weight = fix_recip31(m_R) / 2 */
#define INFO_KEEP_RANGE 6     /* units kept while the largest weight >= 2^24 */

/* y0 in units: 2^(e − 24); after 2+ halvings (~2^29 readings) at least 1 unit, a tighter
 * prior than P0, still negligible beside the data. */
static uint64_t info_y0(const struct kalman_info *in) {
    const int32_t sh = in->e - 24;
    return sh >= 0 ? (uint64_t)1 << (unsigned)sh : 1u;
}

/* Every sum shifted right by sh: sh units coarser. */
static void info_coarser(struct kalman_info *in, unsigned sh) {
    for (unsigned s = 0; s < ANGLES_SENSORS; ++s) {
        in->a[s] >>= sh;
        in->z[s] = fix_floor_shr_s64(in->z[s], sh);
    }
    in->e -= (int32_t)sh;
}

/* The weights of one reading for the current R, in the units of the sums: chosen afresh
 * when the sums are empty, else kept while the largest weight stays in [2^24, 2^30] (a
 * smaller R makes the sums coarser; a larger one finer when they have the room). */
static void info_set_weights(struct kalman_state *k) {
    struct kalman_info *in = kalman_info_of(k);
    fix_q32_t r_min = k->r[0];
    for (unsigned s = 1; s < ANGLES_SENSORS; ++s) {
        r_min = k->r[s] < r_min ? k->r[s] : r_min;
    }
    int32_t er;
    (void)fix_norm31_inline((uint64_t)r_min, &er);
    /* weight of R = m·2^er: fix_recip31(m) · 2^(e + 32 − 61 − er) */
    const int32_t want = 29 + INFO_W_SHIFT + er;
    const bool empty = (in->a[0] | in->a[1] | in->a[2] | in->a[3]) == 0u;
    if (empty) {
        in->e = want;
    } else if (want < in->e) {
        const int32_t sh = in->e - want;
        info_coarser(in, (unsigned)sh);
    } else if (want > in->e + INFO_KEEP_RANGE) {
        const int32_t finer = want - in->e;
        const unsigned sh = (unsigned)finer;
        bool room = true;
        for (unsigned s = 0; s < ANGLES_SENSORS; ++s) {
            room = room && in->a[s] < (INFO_SUM_CHECK >> sh) &&
                   fix_abs_u64(in->z[s]) < (INFO_SUM_CHECK >> sh);
        }
        if (room) {
            for (unsigned s = 0; s < ANGLES_SENSORS; ++s) {
                in->a[s] <<= sh;
                in->z[s] *= (int64_t)1 << sh;
            }
            in->e = want;
        } /* else the weights keep fewer bits (at least 2^12 of the largest) */
    } else {
        /* the units stay */
    }
    for (unsigned s = 0; s < ANGLES_SENSORS; ++s) {
        int32_t e;
        const uint32_t m = fix_norm31_inline((uint64_t)k->r[s], &e);
        const uint32_t rr = (uint32_t)fix_recip31_inline(m); /* 2^61/m, in (2^30, 2^31] */
        const int32_t sh = in->e + 32 - 61 - e;              /* <= INFO_W_SHIFT */
        const uint32_t w = sh <= -32 ? 0u : rr >> (unsigned)(-sh);
        in->w[s] = w != 0u ? (int32_t)w : 1; /* <= 2^30 */
    }
}

/* |v| for |v| < 2^63 (the sums and quotients of the solve), inline. */
FIX_INLINE uint64_t info_abs(int64_t v) {
    return v < 0 ? (uint64_t)(-v) : (uint64_t)v;
}

/* (v · r) / 2^31 for v < 2^59 and r < 2^32: two 32x32 products, truncated. */
FIX_INLINE uint64_t info_mul(uint64_t v, uint32_t r) {
    const uint64_t hi = (v >> 32) * r;             /* < 2^59 */
    const uint64_t lo = (uint64_t)(uint32_t)v * r; /* < 2^64 */
    return (hi << 1) + (lo >> 31);
}

static int64_t info_mul_s(int64_t v, int32_t r) {
    const bool neg = (v < 0) != (r < 0);
    const uint64_t m = info_mul(info_abs(v), r < 0 ? (uint32_t)(-(int64_t)r) : (uint32_t)r);
    return neg ? -(int64_t)m : (int64_t)m;
}

/* v << sh for sh >= 0, v >> −sh otherwise (sh in [−63, 63]; the callers' results fit). */
FIX_INLINE uint64_t info_shift(uint64_t v, int32_t sh) {
    return sh >= 0 ? v << (unsigned)sh : (sh > -64 ? v >> (unsigned)(-sh) : 0u);
}

/* v / D in Q31 for v <= D = m · 2^e (r = fix_recip31(m) ≈ 2^61/m): at most 2^31. */
FIX_INLINE uint32_t info_ratio(uint64_t v, int32_t e, uint32_t r) {
    const uint32_t t = (uint32_t)info_shift(v, -e); /* <= m < 2^31 */
    return (uint32_t)(((uint64_t)t * r) >> 30);
}

/* z · v / D (units·mm) for v <= 2D: v's own mantissa, so a small v keeps its bits. */
static int64_t info_scaled(int64_t z, uint64_t v, int32_t e, uint32_t r) {
    if (v == 0u) {
        return 0;
    }
    int32_t ev;
    const uint32_t mv = fix_norm31_inline(v, &ev);
    const uint32_t t = (uint32_t)(((uint64_t)mv * r) >> 30); /* v/D · 2^(31 + e − ev) */
    const uint64_t q = info_shift(info_mul(info_abs(z), t), ev - e);
    return z < 0 ? -(int64_t)q : (int64_t)q;
}

/* v · 2^32 / D as Q32 (v in units·mm: mm; v = 2^e units: mm²), D = m · 2^e_d. */
static int64_t info_quotient(int64_t v, int32_t e_d, uint32_t r) {
    if (v == 0) {
        return 0;
    }
    int32_t ev;
    const uint32_t vm = fix_norm31_inline(info_abs(v), &ev);
    const uint64_t prod = (uint64_t)vm * r; /* v/D · 2^(61 + e_d − ev), < 2^62 */
    const int32_t sh = ev - e_d - 29;
    const int32_t right = -sh;
    const unsigned ur = (unsigned)right;
    const uint64_t q = sh >= 0 ? prod << (unsigned)sh
                               : (right < 63 ? (prod + ((uint64_t)1 << (ur - 1u))) >> ur : 0u);
    return v < 0 ? -(int64_t)q : (int64_t)q;
}

/* (v · r) / 2^(31 − fine), truncated, for fine <= 31 and v < 2^(44 − fine), or fine = 0 and
 * v < 2^59 (the solve's finer units, info_factors). */
FIX_INLINE uint64_t info_mul_fine(uint64_t v, uint32_t r, unsigned fine) {
    const uint64_t hi = (v >> 32) * r;
    const uint64_t lo = (uint64_t)(uint32_t)v * r;
    return (hi << (1u + fine)) + (lo >> (31u - fine));
}

/* One axis of the general solve (sensors m and p of its rows, kalman.h): its divisor
 * Y_jj = m · 2^e with r = fix_recip31(m), g = Y_0j/Y_jj, its terms of d and of d·δx̄, and
 * δθ_j before − g_j δx̄. */
struct info_axis {
    uint32_t r;
    int32_t e;
    int32_t g;     /* Q31 */
    uint64_t q;    /* (y0(a_m + a_p) + 4 a_m a_p) / Y_jj, units · 2^-fine */
    int64_t n;     /* ((y0 + 2a_p) ζ_m + (y0 + 2a_m) ζ_p) / Y_jj, units·mm */
    int64_t slope; /* (ζ_p − ζ_m) / Y_jj, Q32 mm */
    bool empty;    /* no reading: Y_jj = y0, nothing couples the axis to x̄ */
};

static void info_axis_solve(const uint64_t a[ANGLES_SENSORS], const int64_t z[ANGLES_SENSORS],
                            unsigned sm, unsigned sp, uint64_t y0, unsigned fine,
                            struct info_axis *ax) {
    const uint64_t am = a[sm];
    const uint64_t ap = a[sp];
    const int64_t zm = z[sm];
    const int64_t zp = z[sp];
    const uint64_t sum = am + ap;
    ax->empty = sum == 0u;
    if (ax->empty) {
        ax->r = 0u;
        ax->e = 0;
        ax->g = 0;
        ax->q = 0u;
        ax->n = 0;
        ax->slope = 0;
        return;
    }
    const uint32_t m = fix_norm31_inline(sum + y0, &ax->e);
    const uint32_t r = (uint32_t)fix_recip31_inline(m);
    const int32_t e = ax->e;
    ax->r = r;
    const uint32_t rm = info_ratio(am, e, r);
    const uint32_t rp = info_ratio(ap, e, r);
    ax->g = (int32_t)((int64_t)rp - (int64_t)rm);
    /* 4 a_m a_p / Y_jj as 4 · min · (max / Y_jj): the ratio at least about 1/2 */
    const uint64_t lo = am < ap ? am : ap;
    const uint32_t r_hi = am < ap ? rp : rm;
    ax->q = info_mul_fine(4u * lo, r_hi, fine) + info_mul_fine(y0, rm + rp, fine);
    ax->n = info_scaled(zm, y0 + 2u * ap, e, r) + info_scaled(zp, y0 + 2u * am, e, r);
    ax->slope = info_quotient(zp - zm, e, r);
}

/* The general solve's factors: both axes and d = m · 2^ed (units) with rd = fix_recip31(m). */
struct info_solution {
    struct info_axis al;
    struct info_axis be;
    uint32_t rd;
    int32_t ed;
};

/* The sums: those stored, or during a uniform run (which stores only its rows and the
 * deviation sums) a_s = n·w_s and ζ_s = w_s·D_s, exact. */
static void info_sums(const struct kalman_info *in, uint64_t a[ANGLES_SENSORS],
                      int64_t z[ANGLES_SENSORS]) {
    for (unsigned s = 0; s < ANGLES_SENSORS; ++s) {
        a[s] = in->uniform ? (uint64_t)in->n * (uint32_t)in->w[s] : in->a[s];
        z[s] = in->uniform ? in->dsum[s] * in->w[s] : in->z[s];
    }
}

/* The end of a uniform run: its sums stored. */
static void info_end_run(struct kalman_info *in) {
    if (in->uniform) {
        info_sums(in, in->a, in->z);
        in->uniform = false;
    }
}

static void info_factors(const struct kalman_info *in, struct info_solution *sol) {
    uint64_t a[ANGLES_SENSORS];
    int64_t z[ANGLES_SENSORS];
    info_sums(in, a, z);
    /* d in finer units (2^-fine) while the sums are small (the first rows: each weight sum
     * below 2^(42 − fine)): its terms' integer parts then keep their bits whatever a weak
     * sensor weighs. */
    const uint64_t y0 = info_y0(in);
    const uint64_t top = a[0] | a[1] | a[2] | a[3] | y0;
    const int32_t fine_bits = 42 - (int32_t)fix_bitlen_u64(top);
    const unsigned fine = fine_bits > 0 ? (fine_bits < 31 ? (unsigned)fine_bits : 31u) : 0u;
    info_axis_solve(a, z, ANGLES_A, ANGLES_C, y0, fine, &sol->al);
    info_axis_solve(a, z, ANGLES_D, ANGLES_B, y0, fine, &sol->be);
    const uint32_t md = fix_norm31_inline((y0 << fine) + sol->al.q + sol->be.q, &sol->ed);
    sol->rd = (uint32_t)fix_recip31_inline(md);
    sol->ed -= (int32_t)fine; /* d in units */
}

/* x from the sums, any rows. */
static void info_solve_general(struct kalman_state *k) {
    const struct kalman_info *in = kalman_info_of_c(k);
    struct info_solution sol;
    info_factors(in, &sol);
    const int64_t dx = info_quotient(sol.al.n + sol.be.n, sol.ed, sol.rd);
    k->x[0] = ((int64_t)in->x0_mm << FIX_Q32_SHIFT) + dx;
    k->x[1] = sol.al.slope - info_mul_s(dx, sol.al.g);
    k->x[2] = sol.be.slope - info_mul_s(dx, sol.be.g);
}

/* The state after no reading: the prior, a uniform run of no rows. */
static void info_prior(struct kalman_state *k) {
    struct kalman_info *in = kalman_info_of(k);
    (void)memset(in->a, 0, sizeof in->a);
    (void)memset(in->z, 0, sizeof in->z);
    (void)memset(in->dsum, 0, sizeof in->dsum);
    in->rows_to_check = INFO_CHECK_ROWS;
    in->uniform = true;
    in->fast_ready = false;
    in->n = 0;
    info_set_weights(k);
    info_solve_general(k); /* x = θ0 */
}

/* One accepted reading of sensor s (the sums' headroom: info_check_sums). */
FIX_INLINE void info_add(struct kalman_info *in, unsigned s, uint16_t range_mm) {
    const int32_t dev = (int32_t)range_mm - in->x0_mm; /* |dev| < 2^17 */
    in->a[s] += (uint32_t)in->w[s];
    in->z[s] += (int64_t)in->w[s] * dev;
}

/* Before a row: every INFO_CHECK_ROWS rows the sums' headroom, halved past INFO_SUM_CHECK
 * (the weights change: the uniform run ends). */
static void info_check_sums(struct kalman_info *in) {
    if (--in->rows_to_check != 0u) {
        return;
    }
    in->rows_to_check = INFO_CHECK_ROWS;
    if (in->uniform) {
        /* its derived sums below 2^58 until the next check: n·w < 2^54 and |D| < 2^28
         * (w <= 2^30; the next 2048 rows add below 2^28 to |D|) */
        bool room = in->n < ((uint32_t)1 << 24);
        for (unsigned s = 0; s < ANGLES_SENSORS; ++s) {
            room = room && info_abs(in->dsum[s]) < ((uint64_t)1 << 28);
        }
        if (room) {
            return;
        }
        info_end_run(in);
    }
    for (unsigned s = 0; s < ANGLES_SENSORS; ++s) {
        if (in->a[s] >= INFO_SUM_CHECK || info_abs(in->z[s]) >= INFO_SUM_CHECK) {
            info_coarser(in, 1u);
            for (unsigned t = 0; t < ANGLES_SENSORS; ++t) {
                in->w[t] = in->w[t] > 1 ? in->w[t] / 2 : 1;
            }
            return;
        }
    }
}

/* P from the sums (either solve). */
void kalman_info_covariance(const struct kalman_state *k,
                            fix_q32_t p[KALMAN_STATES][KALMAN_STATES]) {
    const struct kalman_info *in = kalman_info_of_c(k);
    struct info_solution sol;
    info_factors(in, &sol);
    const int64_t one = (int64_t)1 << (unsigned)in->e; /* 1 mm⁻² in units */
    const fix_q32_t inv_d = info_quotient(one, sol.ed, sol.rd);
    const fix_q32_t inv_a =
        sol.al.empty ? KALMAN_P0_MM2_Q32 : info_quotient(one, sol.al.e, sol.al.r);
    const fix_q32_t inv_b =
        sol.be.empty ? KALMAN_P0_MM2_Q32 : info_quotient(one, sol.be.e, sol.be.r);
    const fix_q32_t ga = info_mul_s(inv_d, sol.al.g); /* g_α/d */
    const fix_q32_t gb = info_mul_s(inv_d, sol.be.g);
    p[0][0] = inv_d;
    p[0][1] = -ga;
    p[0][2] = -gb;
    p[1][1] = inv_a + info_mul_s(ga, sol.al.g);
    p[1][2] = info_mul_s(ga, sol.be.g);
    p[2][2] = inv_b + info_mul_s(gb, sol.be.g);
    p[1][0] = p[0][1];
    p[2][0] = p[0][2];
    p[2][1] = p[1][2];
}

/* The gate of the information form for a reading outside the sure-accept test (info_row):
 * against s = hᵀPh + R with P of the rows before. */
static bool info_gated_out(const struct kalman_state *k, unsigned sensor, fix_q32_t e) {
    const unsigned j = kalman_h_index(sensor);
    const bool minus = kalman_h_minus(sensor);
    fix_q32_t p[KALMAN_STATES][KALMAN_STATES];
    kalman_info_covariance(k, p);
    const fix_q32_t hph = minus ? p[0][0] - 2 * p[0][j] + p[j][j] : p[0][0] + 2 * p[0][j] + p[j][j];
    return kalman_gated_out(k, e, hph + k->r[sensor]);
}

/* One row of the information form: every valid reading gated against the state before
 * the row, the accepted ones added, one solve (the fast one while the run allows it).
 * Returns the sensors accepted. */
uint8_t kalman_info_row(struct kalman_state *k, const uint16_t range_mm[ANGLES_SENSORS],
                        uint8_t valid_mask, bool gate, uint8_t *rejected) {
    uint8_t used = valid_mask;
    if (gate && k->cfg.gate_sigmas_q8 != 0u) {
        /* predictions h·x: A x̄ − θα, B x̄ + θβ, C x̄ + θα, D x̄ − θβ */
        const fix_q32_t pred[ANGLES_SENSORS] = {k->x[0] - k->x[1], k->x[0] + k->x[2],
                                                k->x[0] + k->x[1], k->x[0] - k->x[2]};
        for (unsigned s = 0; s < ANGLES_SENSORS; ++s) {
            if ((valid_mask & (1u << s)) == 0u) {
                continue;
            }
            const fix_q32_t e = ((fix_q32_t)range_mm[s] << FIX_Q32_SHIFT) - pred[s];
            /* |e| < 128 mm (the high word in [−128, 127]) and e24² <= q²R or the floor:
             * inside the gate for any s >= R, P not needed */
            const uint32_t e_hi = (uint32_t)((uint64_t)e >> 32) + 128u;
            if (e_hi <= 255u) {
                const int32_t e24 = shr_to_s32(e + 128, 8u);
                const int64_t e24_sq = (int64_t)e24 * e24;
                if ((uint64_t)e24_sq <= k->gate_accept[s]) {
                    continue;
                }
            }
            if (info_gated_out(k, s, e)) {
                used = (uint8_t)(used & ~(1u << s));
            }
        }
    }
    *rejected = (uint8_t)(valid_mask ^ used); /* used is a subset of valid_mask */
    if (used == 0u) {
        return 0u;
    }
    struct kalman_info *in = kalman_info_of(k);
    if (used != ANGLES_ALL_SENSORS) {
        info_end_run(in);
    }
    info_check_sums(in);
    bool solved = false;
    if (in->uniform) {
        /* the run's rows and deviation sums (each below 2^17 per row) */
        in->dsum[0] += (int32_t)range_mm[0] - in->x0_mm;
        in->dsum[1] += (int32_t)range_mm[1] - in->x0_mm;
        in->dsum[2] += (int32_t)range_mm[2] - in->x0_mm;
        in->dsum[3] += (int32_t)range_mm[3] - in->x0_mm;
        in->n++;
        if (!in->fast_ready) {
            kalman_info_fast_prepare(in);
        }
        solved = kalman_info_fast_solve(k);
    }
    if (!in->uniform) {
        for (unsigned s = 0; s < ANGLES_SENSORS; ++s) {
            if ((used & (1u << s)) != 0u) {
                info_add(in, s, range_mm[s]);
            }
        }
    }
    if (!solved) {
        info_solve_general(k);
    }
    return used;
}

void kalman_info_reset(struct kalman_state *k) {
    kalman_info_of(k)->x0_mm = 0;
    info_prior(k);
}

void kalman_info_start(struct kalman_state *k) {
    /* the information form's prior mean, whole mm: its deviations are integers */
    struct kalman_info *in = kalman_info_of(k);
    in->x0_mm = (int32_t)fix_round_shr_s64(k->x[0], FIX_Q32_SHIFT);
    k->x[0] = (fix_q32_t)in->x0_mm << FIX_Q32_SHIFT;
}

void kalman_info_r_changed(struct kalman_state *k) {
    struct kalman_info *in = kalman_info_of(k);
    if (in->n != 0u) {
        info_end_run(in); /* past readings keep their weights */
    }
    info_set_weights(k); /* may change the units: x again from the sums */
    in->fast_ready = false;
    info_solve_general(k);
}
