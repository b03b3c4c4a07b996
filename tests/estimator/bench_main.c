/*
 * On-target benchmark (docs/reference/performance.md), run under QEMU with -icount shift=7 so the
 * CMSDK timer counts instructions exactly (insn_counter.h). For each operation it
 * prints "BENCH <cpu> <impl> <op> <instructions>", averaged over a workload of
 * BENCH_WINDOWS windows of N = 100 samples of a plate at changing attitudes:
 *   sample     four ranges in, ten angles, window statistics, Kalman update
 *   consensus  one window's product consensus: weights, P, iterated to tolerance
 *   kalman     one four-measurement Kalman update, run as the firmware runs it by
 *              default (tumbling windows: the filter restarts at each window's first
 *              row; the warm-up rows, buffered and then processed at once, excluded)
 *   kalman_track  the same row with process noise (the tracking form, Q = 0.01 mm² per
 *              row on every state), one filter over the whole workload as sliding
 *              windows run it (no restart; the warm-up rows excluded)
 *   kalman_auto  (fixed only) kalman_track's row with `--process-noise auto` (Q and R
 *              learnt from the readings, kalman_adapt.c: the block sums of every row and,
 *              every 32 rows, the samples and the levels' mean, averaged in): a cold start
 *              on a plate stepped every 100 rows, so the learnt Q keeps changing and most
 *              rows run in full (the transient's cost)
 *   kalman_auto_walk  (fixed only) the same filter settled: a plate whose x̄ and slopes
 *              wander as random walks (AUTO_WALK_ROWS rows, the first AUTO_WALK_LEARN not
 *              counted), the operating case `auto` is for
 *   kalman_auto_worst  (fixed only) the most expensive single `auto` row of both workloads
 *   sample_auto_walk  (fixed only) `sample` on that wandering plate with the facade's filter
 *              on `auto` (tumbling windows, as sample_track; the window ends not counted)
 *   sample_track  (fixed only) `sample` with the facade's Kalman filter tracking (the
 *              same Q, tumbling windows: with Q > 0 the filter is not restarted at a
 *              window's start, and R follows each window's statistics)
 *   window     (fixed only) the whole window-end work of all four estimators
 *   sample_cal, sample_thermal  (fixed only) `sample` through the calibrated head of
 *              window_cal over 20,000 rows, without and with temperature coefficients (40,
 *              −30, 25, −35 µm/°C) and a temperature rising one ADC step (0.29 °C) every 620
 *              rows, an orbit's fastest: their difference is the correction's cost, its
 *              re-sums of the rows held included (estimator/src/attitude_thermal.c)
 *   window_cal (fixed only) `window` with a calibrated head, the product's real
 *              configuration (offsets, gains, their sds and correlation non-zero, as
 *              HEAD.cal gives them): the corrected readings are other data, so the paper's
 *              iterations and the gate's searches differ from `window`'s
 * `fixed` is the product's estimator; `float` the plain single-precision baseline
 * in tests/estimator/float_baseline.c. tools/bench_report.py collects the lines.
 * Benchmark code, not firmware: it lives in tests/ because it uses float (the baseline's
 * results); boards/mps2 links it into the bench images with the board's own files.
 */
#include <string.h>

#include "board.h"
#include "estimator/attitude.h"
#include "firmware/app.h"
#include "firmware/text.h"
#include "float_baseline.h"
#include "insn_counter.h"
#include "semihost.h"
#include "test_calibration.h" /* tests/common */

#define BENCH_WINDOWS 10u
#define BENCH_N       100u
/* The tracking benchmarks' process noise per row: 0.01 mm² (0.5 mm²/s at 20 ms). */
#define BENCH_Q_Q32 ((fix_q32_t)42949673)
#define BENCH_Q_UM2 10000u

static struct attitude_state est;
static struct kalman_state kal;
static struct kalman_state kal_track;
static struct kalman_state kal_auto;
static struct attitude_state est_track;
static struct attitude_state est_cal;
static struct attitude_state est_auto;
static struct attitude_state est_cal_only;
static struct attitude_state est_thermal;
static struct flt_window fwin;
static struct flt_kalman fkal;
static struct flt_kalman fkal_track;
static volatile float float_sink; /* keeps the float results alive */
static volatile int32_t fixed_sink;

/* Deterministic workload: an LCG (Numerical Recipes constants) gives a triangular-ish
 * noise of about 1.6 mm on each sensor of a plate whose tilt changes every window. */
static uint32_t lcg_state = 12345u;
static int32_t noise_mm(void) {
    int32_t sum = 0;
    for (unsigned i = 0; i < 4u; ++i) {
        lcg_state = lcg_state * 1664525u + 1013904223u;
        sum += (int32_t)((lcg_state >> 29) % 5u) - 2; /* -2..2 */
    }
    return sum / 2;
}

static void make_sample(unsigned window, uint16_t range[4]) {
    /* a·tan α and a·tan β in mm for the window's attitude: up to ±3 mm (±5.7° at a = 30). */
    const int32_t ta = (int32_t)(window % 7u) - 3;
    const int32_t tb = 2 - (int32_t)(window % 5u);
    const int32_t mean = 100;
    range[0] = (uint16_t)(mean - ta + noise_mm());
    range[1] = (uint16_t)(mean + tb + noise_mm());
    range[2] = (uint16_t)(mean + ta + noise_mm());
    range[3] = (uint16_t)(mean - tb + noise_mm());
}

/* What head c reads for the workload's range x (mm): raw = gain · x + offset, to the
 * nearest mm, so that the correction gives back the workload's plate. */
static uint16_t head_reading(const struct calibration_head *c, unsigned k, uint16_t x) {
    const int64_t raw_um =
        (int64_t)x * (1000000 + c->gain_ppm[k]) / 1000 + (int64_t)c->offset_um[k];
    return (uint16_t)((raw_um + 500) / 1000);
}

static void report(const char *cpu, const char *impl, const char *op, uint64_t total,
                   uint32_t count) {
    char line[96];
    struct tof_text t;
    tof_text_init(&t, line, sizeof line);
    tof_text_str(&t, "BENCH ");
    tof_text_str(&t, cpu);
    tof_text_str(&t, " ");
    tof_text_str(&t, impl);
    tof_text_str(&t, " ");
    tof_text_str(&t, op);
    tof_text_str(&t, " ");
    tof_text_u64(&t, count > 0u ? (total + count / 2u) / count : 0u);
    tof_text_str(&t, "\n");
    semihost_write_stdout(line, t.len);
}

/* The measurement's own cost (two timer reads), subtracted from every figure. */
static uint64_t overhead;
static uint64_t measured(uint32_t before, uint32_t after) {
    const uint64_t n = insn_counter_between(before, after);
    return n > overhead ? n - overhead : 0u;
}

/* The settled `auto` filter on a wandering plate: x̄ and the two slopes each take a step of
 * ±STEP µm a row (q = STEP² per row: 0.02 mm²/s at 20 ms for the slopes, 0.5 for x̄), the
 * workload's LCG noise on each reading. Reports the mean over the settled rows and returns
 * the most expensive row (instructions). */
#define AUTO_WALK_ROWS  4000u
#define AUTO_WALK_LEARN 2000u
static uint64_t bench_auto_walk(const char *cpu, const struct kalman_config *acfg,
                                const struct attitude_config *auto_cfg) {
    if (kalman_init(&kal_auto, acfg) != KALMAN_OK ||
        attitude_init(&est_auto, auto_cfg) != ATTITUDE_ERR_NONE) {
        semihost_write_stdout("bench: kalman_init (walk) failed\n", 33);
        semihost_exit(1);
    }
    int32_t xbar_um = 100000;
    int32_t ta_um = 1000;
    int32_t tb_um = -1000;
    uint64_t total = 0;
    uint64_t worst = 0;
    uint64_t sample_total = 0;
    uint32_t samples = 0;
    const uint8_t status[4] = {0, 0, 0, 0};
    const bool present[4] = {true, true, true, true};
    for (uint32_t r = 0; r < AUTO_WALK_ROWS; ++r) {
        lcg_state = lcg_state * 1664525u + 1013904223u;
        xbar_um += (lcg_state & 0x10000000u) != 0u ? 100 : -100;
        ta_um += (lcg_state & 0x20000000u) != 0u ? 20 : -20;
        tb_um += (lcg_state & 0x40000000u) != 0u ? 20 : -20;
        const int32_t m[4] = {xbar_um - ta_um, xbar_um + tb_um, xbar_um + ta_um, xbar_um - tb_um};
        uint16_t range[4];
        for (unsigned k = 0; k < 4u; ++k) {
            range[k] = (uint16_t)((m[k] + 500) / 1000 + noise_mm());
        }
        struct kalman_rows rows;
        const uint32_t k0 = insn_counter_ticks();
        kalman_push_row(&kal_auto, range, 0x0Fu, &rows);
        const uint32_t k1 = insn_counter_ticks();
        const uint64_t n = measured(k0, k1);
        if (r >= AUTO_WALK_LEARN) {
            total += n;
        }
        if (r >= acfg->warmup_rows && n > worst) {
            worst = n;
        }
        struct attitude_output out;
        const uint32_t s0 = insn_counter_ticks();
        const bool ready = attitude_push_sample(&est_auto, range, status, present, &out);
        const uint32_t s1 = insn_counter_ticks();
        if (!ready && r >= AUTO_WALK_LEARN) {
            sample_total += measured(s0, s1);
            ++samples;
        }
    }
    report(cpu, "fixed", "kalman_auto_walk", total, AUTO_WALK_ROWS - AUTO_WALK_LEARN);
    report(cpu, "fixed", "sample_auto_walk", sample_total, samples);
    return worst;
}

/* sample_cal and sample_thermal: THERMAL_ROWS rows of the workload through the calibrated head,
 * without and with temperature coefficients, the head's temperature rising by one ADC step
 * (0.29 °C) every THERMAL_ROWS_PER_STEP rows, an orbit's fastest (a 40 °C cycle of 90 minutes
 * at 50 Hz: 1.4 °C/min). Rows that end no window, as `sample`. */
#define THERMAL_ROWS          20000u
#define THERMAL_ROWS_PER_STEP 620u
static void bench_thermal(const char *cpu, const struct attitude_config *cal_cfg) {
    struct attitude_config thermal_cfg = *cal_cfg;
    thermal_cfg.calibration.thermal = true;
    thermal_cfg.calibration.cal_temp_cdeg = 2000;
    const int32_t coeff_nm_per_c[4] = {40000, -30000, 25000, -35000};
    for (unsigned k = 0; k < 4u; ++k) {
        thermal_cfg.calibration.temp_coeff_nm_per_c[k] = coeff_nm_per_c[k];
        thermal_cfg.calibration.temp_coeff_sd_nm_per_c[k] = 2000u;
    }
    if (attitude_init(&est_cal_only, cal_cfg) != ATTITUDE_ERR_NONE ||
        attitude_init(&est_thermal, &thermal_cfg) != ATTITUDE_ERR_NONE) {
        semihost_write_stdout("bench: attitude_init (thermal) failed\n", 38);
        semihost_exit(1);
    }
    const uint8_t status[4] = {0, 0, 0, 0};
    const bool present[4] = {true, true, true, true};
    uint64_t cal_only_total = 0, thermal_total = 0;
    uint32_t samples = 0;
    lcg_state = 12345u;
    for (uint32_t row = 0; row < THERMAL_ROWS; ++row) {
        uint16_t range[4];
        make_sample(row / BENCH_N, range);
        const int32_t temp_cdeg = 2000 + 29 * (int32_t)(row / THERMAL_ROWS_PER_STEP);
        uint16_t raw[4];
        for (unsigned k = 0; k < 4u; ++k) {
            /* the head's reading at the workload's range, its offset moved by temperature */
            const int32_t shift_um = coeff_nm_per_c[k] * (temp_cdeg - 2000) / 100000;
            const int32_t at_cal = head_reading(&cal_cfg->calibration, k, range[k]);
            raw[k] = (uint16_t)(at_cal + (shift_um + (shift_um < 0 ? -500 : 500)) / 1000);
        }
        struct attitude_output out;
        const uint32_t p0 = insn_counter_ticks();
        const bool cal_only_ready = attitude_push_sample(&est_cal_only, raw, status, present, &out);
        const uint32_t p1 = insn_counter_ticks();
        attitude_set_temperature(&est_thermal, true, (int16_t)temp_cdeg);
        const bool thermal_ready = attitude_push_sample(&est_thermal, raw, status, present, &out);
        const uint32_t p2 = insn_counter_ticks();
        if (!cal_only_ready && !thermal_ready) {
            cal_only_total += measured(p0, p1);
            thermal_total += measured(p1, p2); /* attitude_set_temperature included */
            ++samples;
        }
    }
    report(cpu, "fixed", "sample_cal", cal_only_total, samples);
    report(cpu, "fixed", "sample_thermal", thermal_total, samples);
}

static void bench_fixed(const char *cpu) {
    struct attitude_config cfg;
    attitude_config_default(&cfg);
    if (attitude_init(&est, &cfg) != ATTITUDE_ERR_NONE) {
        semihost_write_stdout("bench: attitude_init failed\n", 28);
        semihost_exit(1);
    }
    const struct kalman_config kcfg = {
        .initial_noise_mm2 = {(fix_q32_t)4 << 32, (fix_q32_t)4 << 32, (fix_q32_t)4 << 32,
                              (fix_q32_t)4 << 32},
        .gate_sigmas_q8 = 5u * 256u,
        .gate_floor_mm = 3,
        .warmup_rows = 5,
        .noise_shift = 2,
    };
    struct kalman_config tcfg = kcfg;
    tcfg.process_noise_mm2[0] = BENCH_Q_Q32;
    tcfg.process_noise_mm2[1] = BENCH_Q_Q32;
    tcfg.process_noise_mm2[2] = BENCH_Q_Q32;
    struct kalman_config acfg = kcfg;
    acfg.process_noise_auto = true;
    struct attitude_config track_cfg = cfg;
    for (unsigned i = 0; i < KALMAN_STATES; ++i) {
        track_cfg.kalman_process_noise_um2[i] = BENCH_Q_UM2;
    }
    struct attitude_config cal_cfg = cfg;
    test_calibration_fitted(&cal_cfg.calibration);
    if (attitude_init(&est_cal, &cal_cfg) != ATTITUDE_ERR_NONE) {
        semihost_write_stdout("bench: attitude_init (calibrated) failed\n", 41);
        semihost_exit(1);
    }
    if (kalman_init(&kal, &kcfg) != KALMAN_OK || kalman_init(&kal_track, &tcfg) != KALMAN_OK ||
        kalman_init(&kal_auto, &acfg) != KALMAN_OK ||
        attitude_init(&est_track, &track_cfg) != ATTITUDE_ERR_NONE) {
        semihost_write_stdout("bench: kalman_init failed\n", 26);
        semihost_exit(1);
    }
    uint64_t sample_total = 0, window_total = 0, consensus_total = 0, kalman_total = 0;
    uint64_t track_total = 0, sample_track_total = 0, auto_total = 0, window_cal_total = 0;
    uint32_t windows_cal = 0;
    uint64_t auto_worst = 0;
    uint32_t samples = 0, windows = 0, kalman_rows = 0, track_rows = 0, track_samples = 0;
    const uint8_t status[4] = {0, 0, 0, 0};
    const bool present[4] = {true, true, true, true};
    lcg_state = 12345u;
    for (unsigned w = 0; w < BENCH_WINDOWS; ++w) {
        for (unsigned i = 0; i < BENCH_N; ++i) {
            uint16_t range[4];
            make_sample(w, range);
            struct attitude_output out;
            const uint32_t t0 = insn_counter_ticks();
            const bool ready = attitude_push_sample(&est, range, status, present, &out);
            const uint32_t t1 = insn_counter_ticks();
            if (ready) {
                window_total += measured(t0, t1);
                ++windows;
                fixed_sink = out.est[ATTITUDE_EST_CONSENSUS].alpha_udeg;
            } else {
                sample_total += measured(t0, t1);
                ++samples;
            }
            struct kalman_rows rows;
            if (i == 0u) {
                kalman_reset(&kal); /* what attitude_push_sample() does in tumbling mode */
            }
            const uint32_t k0 = insn_counter_ticks();
            kalman_push_row(&kal, range, 0x0Fu, &rows);
            const uint32_t k1 = insn_counter_ticks();
            if (i >= kcfg.warmup_rows) { /* past the warm-up buffer: one real update */
                kalman_total += measured(k0, k1);
                ++kalman_rows;
            }
            const uint32_t k2 = insn_counter_ticks();
            kalman_push_row(&kal_track, range, 0x0Fu, &rows);
            const uint32_t k3 = insn_counter_ticks();
            if (w > 0u || i >= kcfg.warmup_rows) {
                track_total += measured(k2, k3);
                ++track_rows;
            }
            const uint32_t k4 = insn_counter_ticks();
            kalman_push_row(&kal_auto, range, 0x0Fu, &rows);
            const uint32_t k5 = insn_counter_ticks();
            if (w > 0u || i >= kcfg.warmup_rows) {
                const uint64_t n = measured(k4, k5);
                auto_total += n;
                auto_worst = n > auto_worst ? n : auto_worst;
            }
            const uint32_t s0 = insn_counter_ticks();
            const bool track_ready = attitude_push_sample(&est_track, range, status, present, &out);
            const uint32_t s1 = insn_counter_ticks();
            if (!track_ready) {
                sample_track_total += measured(s0, s1);
                ++track_samples;
            }
            uint16_t raw[4];
            for (unsigned k = 0; k < 4u; ++k) {
                raw[k] = head_reading(&cal_cfg.calibration, k, range[k]);
            }
            const uint32_t e0 = insn_counter_ticks();
            const bool cal_ready = attitude_push_sample(&est_cal, raw, status, present, &out);
            const uint32_t e1 = insn_counter_ticks();
            if (cal_ready) {
                window_cal_total += measured(e0, e1);
                ++windows_cal;
                fixed_sink = out.est[ATTITUDE_EST_CONSENSUS].alpha_udeg;
            }
        }
        /* The product consensus of this window, from its statistics. */
        struct consensus_product_input in;
        memset(&in, 0, sizeof in);
        in.arm_um = cfg.arm_um;
        in.tolerance_udeg = cfg.consensus_tolerance_udeg;
        for (unsigned k = 0; k < 4u; ++k) {
            in.sensor[k].used = est.stats.sensor[k].used != 0u;
            in.sensor[k].count = est.stats.sensor[k].used;
            in.sensor[k].mean_mm = est.stats.sensor[k].mean_mm;
            in.sensor[k].var_mm2 = est.stats.sensor[k].var_mm2;
        }
        struct consensus_product_result res;
        const uint32_t c0 = insn_counter_ticks();
        consensus_product(&in, &res);
        const uint32_t c1 = insn_counter_ticks();
        consensus_total += measured(c0, c1);
        fixed_sink = res.alpha.angle_udeg;
    }
    report(cpu, "fixed", "sample", sample_total, samples);
    report(cpu, "fixed", "consensus", consensus_total, BENCH_WINDOWS);
    report(cpu, "fixed", "kalman", kalman_total, kalman_rows);
    report(cpu, "fixed", "kalman_track", track_total, track_rows);
    report(cpu, "fixed", "kalman_auto", auto_total, track_rows);
    struct attitude_config auto_cfg = cfg;
    auto_cfg.kalman_process_noise_auto = true;
    const uint64_t walk_worst = bench_auto_walk(cpu, &acfg, &auto_cfg);
    report(cpu, "fixed", "kalman_auto_worst", walk_worst > auto_worst ? walk_worst : auto_worst,
           1u);
    report(cpu, "fixed", "sample_track", sample_track_total, track_samples);
    report(cpu, "fixed", "window", window_total, windows);
    report(cpu, "fixed", "window_cal", window_cal_total, windows_cal);
    bench_thermal(cpu, &cal_cfg);
}

static void bench_float(const char *cpu) {
    uint64_t sample_total = 0, consensus_total = 0, kalman_total = 0, track_total = 0;
    uint32_t samples = 0;
    lcg_state = 12345u;
    flt_kalman_init(&fkal_track, 30.0f, 4.0f);
    /* the same Q per row as the fixed benchmark, in the float state's units (tan²) */
    flt_kalman_set_process_noise(&fkal_track, 0.01f, 0.01f / 900.0f, 0.01f / 900.0f);
    for (unsigned w = 0; w < BENCH_WINDOWS; ++w) {
        flt_window_init(&fwin, 30.0f);
        flt_kalman_init(&fkal, 30.0f, 4.0f);
        for (unsigned i = 0; i < BENCH_N; ++i) {
            uint16_t range[4];
            make_sample(w, range);
            const uint32_t t0 = insn_counter_ticks();
            flt_window_push(&fwin, range);
            const uint32_t t1 = insn_counter_ticks();
            flt_kalman_update(&fkal, range);
            const uint32_t t2 = insn_counter_ticks();
            sample_total += measured(t0, t1) + measured(t1, t2);
            kalman_total += measured(t1, t2);
            const uint32_t t3 = insn_counter_ticks();
            flt_kalman_update(&fkal_track, range);
            const uint32_t t4 = insn_counter_ticks();
            track_total += measured(t3, t4);
            ++samples;
        }
        struct flt_result res;
        const uint32_t c0 = insn_counter_ticks();
        flt_consensus(&fwin, 0.001f, &res);
        const uint32_t c1 = insn_counter_ticks();
        consensus_total += measured(c0, c1);
        float_sink = res.alpha_deg + fkal.x[1] + fkal_track.x[1];
    }
    report(cpu, "float", "sample", sample_total, samples);
    report(cpu, "float", "consensus", consensus_total, BENCH_WINDOWS);
    report(cpu, "float", "kalman", kalman_total, samples);
    report(cpu, "float", "kalman_track", track_total, samples);
}

int main(void) {
    const char *cpu = BOARD_CPU;
    insn_counter_start();
    const uint32_t a = insn_counter_ticks();
    const uint32_t b = insn_counter_ticks();
    overhead = insn_counter_between(a, b);
    bench_fixed(cpu);
    bench_float(cpu);
    return 0;
}

void board_exit(int status) {
    semihost_exit(status < 0 ? -status : status);
}

void board_fault(const char *what) {
    semihost_write_stdout("FAULT: ", 7);
    semihost_write_stdout(what, strlen(what));
    semihost_write_stdout("\n", 1);
    semihost_exit(128);
}
